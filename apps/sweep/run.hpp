#pragma once
// One simulation run of a scene with its outputs: stats.csv (a row per step), summary.json,
// VTK snapshots with a .pvd collection. Every file is written under a temporary name and
// renamed when complete, so a file either is whole or is not there.
#include <atomic>
#include <iosfwd>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "apps/sweep/actuator_output.hpp"
#include "apps/sweep/scene_file.hpp"
#include "integrators/time_stepper.hpp"

namespace sweep {

// A state to start a run from: what a run writes to final_state.csv (the time, q and v), so
// that one settled heap can be spread many times ("settle once, spread many").
struct SavedState {
  double t = 0.0;
  VectorX q, v;
};

// Reads a final_state.csv written by `sweep run` for `scene`. InputError naming the file, the
// line and the value for a missing file, a malformed row, a value that is not finite, a state
// of another size than the model's (nq, nv), a time before 0, a coordinate beyond 1e6, a
// quaternion that is not unit, a joint past its limits or off its mimic coupling by more than
// 1e-2, or two bodies overlapping by more than max(max_overlap, a tenth of the smaller one's
// bounding radius).
SavedState readSavedState(const std::string& path, const Scene& scene, double max_overlap);

// The checks of a saved state once read, `path` naming its source in messages; also for a
// state set from Python.
void checkState(const Scene& scene, const SavedState& state, double max_overlap,
                const std::string& path);

// The same from the file's text; `path` names it in messages.
SavedState readSavedStateText(const std::string& text, const std::string& path, const Scene& scene,
                              double max_overlap);

struct RunOptions {
  std::string out_dir;                      // empty: no files
  bool progress = false;                    // report progress on `log`
  bool progress_bar = false;                // redraw one line (terminal) rather than print lines
  std::ostream* log = nullptr;              // progress and messages; null: silent
  const std::atomic<bool>* stop = nullptr;  // set by a signal: stop after the current step
  bool keep_iterations = false;             // keep every step's iteration counts in the summary
  const SavedState* start = nullptr;        // null: the scene's own q0, v0 at t = 0
};

struct Distribution {
  double mean = 0.0, p50 = 0.0, p95 = 0.0, p99 = 0.0, max = 0.0;
};
Distribution distributionOf(const std::vector<int>& values);

// The same distribution from counts of each value: memory grows with the distinct values, not
// with the steps.
class IterationHistogram {
 public:
  void add(int value) { ++counts_[value]; }
  Distribution distribution() const;

 private:
  std::map<int, long> counts_;
};

struct RunSummary {
  std::string scheme;
  // the state ran away (RunawayError): the message; the outputs hold the run up to that step
  std::string failure;
  int threads = 1;  // the solves' threads (cpu_seconds adds up every thread's time)
  double dt = 0.0, t_end = 0.0, t_reached = 0.0;
  long steps = 0;
  double cpu_seconds = 0.0, wall_seconds = 0.0;
  double penetration_cumulative = 0.0;     // sum over steps of the end-of-step sum of max(0,-g)
  double penetration_time_integral = 0.0;  // the same sum weighted by h
  double penetration_peak = 0.0;
  // the mean overlap of an overlapping contact at a step's end, over the run, and the scale
  // both are read against (ContactModel::smallest_size)
  double penetration_mean = 0.0, smallest_size = 0.0;
  Distribution iterations;  // per step: stage 1 + stage 2
  Distribution iterations_stage1, iterations_stage2;
  long cap_hit_steps = 0;
  double mean_active = 0.0;
  int max_active = 0;
  double mean_candidates = 0.0;
  // solves per step: 1, or the rounds of candidate screening (scheme.screening)
  double mean_solves = 1.0;
  int max_solves = 1;
  // detection.verify_margin: steps detected and solved again because their end velocities
  // outran the margin, and steps that still did after the last detection allowed
  bool margin_verified = false;
  long redetection_steps = 0, margin_outrun_steps = 0;
  // scheme.projection: steps that projected, rounds and solver iterations over all steps
  long projection_steps = 0, projection_rounds = 0, projection_iterations = 0;
  long updates = 0;            // local solves, all steps
  double solve_seconds = 0.0;  // time in stage 5, all steps
  double energy_initial = 0.0, energy_final = 0.0;
  bool interrupted = false;
  // a run on MPI ranks (runSceneOnRanks): their count, the bytes they sent and the bodies
  // they shared per step (means over the steps), and the largest work imbalance of a step
  int ranks = 1;
  double bytes_per_step = 0.0, shared_bodies_per_step = 0.0, imbalance_max = 0.0;
  std::vector<int> iterations_per_step;  // when RunOptions::keep_iterations
  std::vector<ActuatorSummary> actuators;
};

// Runs `scene` from t = 0 (or options.start's t) to settings.t_end. Throws InputError for bad
// settings, and std::runtime_error when an output cannot be written or the state stops being
// finite.
RunSummary runScene(const Scene& scene, const RunSettings& settings, const RunOptions& options);

// The steps of a run from t_start to t_end: the nearest integer to (t_end - t_start) / h.
// InputError, naming time.end and time.step, for less than one step or more than kMaxSteps.
inline constexpr long kMaxSteps = 2000000000L;
long stepCount(double t_start, double t_end, double h);

// JSON text of a document, indented by 2; NaN and infinities become null.
std::string jsonText(const nlohmann::ordered_json& json);

// summary.json's document, and the file written atomically
nlohmann::ordered_json summaryJson(const RunSummary& summary);
void writeSummaryJson(const RunSummary& summary, const std::string& path);

// Shortest text that reads back to the same double (std::to_chars).
std::string exactNumber(double x);

// Writes `text` to `path` through a temporary file and a rename.
void writeFileAtomically(const std::string& path, const std::string& text);
// InputError unless `path` is absent or a regular file: a folder, a device or a FIFO there would
// be replaced by the output's rename (as root, /dev/null), or found only when it is written.
void requireOutputFile(const std::string& path);

}  // namespace sweep
