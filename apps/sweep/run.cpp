#include "apps/sweep/run.hpp"

#include "apps/sweep/run_recorder.hpp"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <optional>
#include <ostream>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#include "apps/sweep/layer_output.hpp"
#include "apps/sweep/signals.hpp"
#include "apps/sweep/vtk_writer.hpp"
#include "apps/sweep/yaml_field.hpp"
#include "framework/error.hpp"

namespace sweep {

namespace fs = std::filesystem;

// this process's CPU time (every thread), in seconds
static double processCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

namespace {

std::string formatDuration(double seconds) {
  std::ostringstream s;
  if (!std::isfinite(seconds)) return "?";
  const long total = std::lround(seconds);
  if (total >= 3600) s << total / 3600 << "h";
  if (total >= 60)
    s << std::setw(total >= 3600 ? 2 : 1) << std::setfill('0') << (total / 60) % 60 << "m";
  s << std::setw(total >= 60 ? 2 : 1) << std::setfill('0') << total % 60 << "s";
  return s.str();
}

}  // namespace

// A file written step by step under its temporary name (PATH.partial, removed if a signal stops
// the process mid-step), renamed into place when the run ends
struct StreamedFile {
  explicit StreamedFile(std::string path_) : path(std::move(path_)), partial(path + ".partial") {
    out.open(path + ".partial", std::ios::binary);
    if (!out) throw std::runtime_error(path + ".partial: cannot open for writing");
  }
  // a full disk stops the run at once rather than computing results nobody gets
  void checkEvery(long step) {
    if (step % 1024 == 0 && !out.flush())
      throw std::runtime_error(path + ".partial: cannot write at step " + std::to_string(step) +
                               " (disk full?)");
  }
  void finish() {
    out.close();
    if (!out) throw std::runtime_error(path + ": cannot write (disk full?)");
    std::error_code error;
    fs::rename(path + ".partial", path, error);
    if (error) throw std::runtime_error(path + ": cannot rename into place");
  }
  std::string path;
  PartialFile partial;
  std::ofstream out;
};

namespace {

// stats.csv: a header of the statistics' names, then one row per step (visitStepStats)
void writeStatsHeader(std::ostream& out, bool timings, const std::vector<std::string>& extra) {
  const char* separator = "";
  visitStepStats(StepStats{}, timings, [&](const char* name, const auto&) {
    out << separator << name;
    separator = ",";
  });
  for (const std::string& name : extra) out << ',' << name;
  out << '\n';
}

void appendStatsRow(std::ostream& out, const StepStats& s, bool timings,
                    const std::vector<double>& extra) {
  const char* separator = "";
  visitStepStats(s, timings, [&](const char*, const auto& value) {
    using Value = std::decay_t<decltype(value)>;
    out << separator;
    separator = ",";
    if constexpr (std::is_same_v<Value, double>)
      out << exactNumber(value);
    else if constexpr (std::is_same_v<Value, bool>)
      out << (value ? 1 : 0);
    else if constexpr (std::is_same_v<Value, SolverStatus>)
      out << enumName(value);
    else
      out << value;
  });
  for (const double x : extra) out << ',' << exactNumber(x);
  out << '\n';
}

}  // namespace

class Progress {
 public:
  Progress(const RunOptions& options, long steps)
      : options_(options), steps_(steps), start_(Clock::now()), last_(start_) {}

  // t: the simulated time reached (absolute: a restarted run does not start at 0)
  void update(long step, double t, bool last) {
    if (!options_.progress || options_.log == nullptr) return;
    const auto now = Clock::now();
    const double since = std::chrono::duration<double>(now - last_).count();
    // a bar redraws 5 times a second; plain lines every 5 s, enough for a log file
    if (!last && since < (options_.progress_bar ? 0.2 : 5.0)) return;
    last_ = now;
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    const double rate = elapsed > 0.0 ? step / elapsed : 0.0;
    const double eta = rate > 0.0 ? (steps_ - step) / rate : NAN;
    const double fraction = static_cast<double>(step) / static_cast<double>(steps_);
    std::ostream& out = *options_.log;
    std::ostringstream line;
    line << std::fixed << std::setprecision(0) << std::setw(3) << 100.0 * fraction << "% step "
         << step << "/" << steps_ << "  t = " << std::setprecision(5) << t << " s  "
         << std::setprecision(0) << rate << " steps/s  ETA " << formatDuration(eta);
    if (options_.progress_bar) {
      const int width = 24;
      const int filled = static_cast<int>(fraction * width);
      out << "\r[" << std::string(filled, '#') << std::string(width - filled, ' ') << "] "
          << line.str() << "   " << (last ? "\n" : "") << std::flush;
    } else {
      out << line.str() << "\n" << std::flush;
    }
  }

 private:
  using Clock = std::chrono::steady_clock;
  const RunOptions& options_;
  long steps_;
  Clock::time_point start_, last_;
};

long stepCount(double t_start, double t_end, double h) {
  if (!(h > 0.0) || !std::isfinite(h))
    throw InputError("time.step must be > 0 and finite, got " + exactNumber(h));
  if (!(t_end > 0.0) || !std::isfinite(t_end))
    throw InputError("time.end must be > 0 and finite, got " + exactNumber(t_end));
  // at the speed bound a body would cross the coordinate bound within one longer step
  if (h > kMaxStep)
    throw InputError("time.step = " + exactNumber(h) + " s is longer than " +
                     formatValue(kMaxStep) + " s: in one step a body at " + formatValue(kMaxSpeed) +
                     " m/s would leave the " + formatValue(kMaxCoordinate) +
                     " m that a scene may span");
  // counted in double: (t_end - t_start) / h can exceed any integer type
  const double count = (t_end - t_start) / h;
  const std::string span =
      "time.end = " + exactNumber(t_end) + " s with time.step = " + exactNumber(h) + " s";
  if (!(count >= 1.0 - 1e-9))
    throw InputError(span + (t_start != 0.0 ? " leaves no step after the saved state's t = " +
                                                  exactNumber(t_start) + " s"
                                            : ": the end comes before the first step does"));
  if (!(count <= static_cast<double>(kMaxSteps) + 0.5))
    throw InputError(span + " is " +
                     (std::isfinite(count) ? formatValue(count) : std::string("more than 1e308")) +
                     " steps, more than the 2e+09 a run may take");
  return std::lround(count);
}

std::string exactNumber(double x) {
  char text[32];
  const auto end = std::to_chars(text, text + sizeof text, x).ptr;
  return std::string(text, end);
}

void requireOutputFile(const std::string& path) {
  std::error_code error;
  // followed: a link to a regular file is replaced like one, a link to /dev/null is not
  const fs::file_status status = fs::status(path, error);
  if (status.type() == fs::file_type::not_found || status.type() == fs::file_type::regular) return;
  if (error && status.type() == fs::file_type::none)
    throw InputError(path + ": cannot check the output path: " + error.message());
  throw InputError(path + ": exists and is not a regular file (" +
                   (fs::is_directory(status) ? "a folder" : "a device, a FIFO or a socket") +
                   "); Sweep writes its outputs as regular files only");
}

void writeFileAtomically(const std::string& path, const std::string& text) {
  requireOutputFile(path);
  const PartialFile registered(path + ".partial");
  const std::string& partial = registered.path();
  std::error_code error;
  {
    std::ofstream out(partial, std::ios::binary);
    out << text;
    out.flush();
    if (!out.good()) {
      fs::remove(partial, error);  // nothing half-written stays behind
      throw std::runtime_error(partial + ": cannot write (disk full?)");
    }
  }
  fs::rename(partial, path, error);
  if (error) {
    const std::string why = error.message();
    fs::remove(partial, error);
    throw std::runtime_error(path + ": cannot rename into place: " + why);
  }
}

RunRecorder::RunRecorder(const Scene& scene, const RunSettings& settings, const RunOptions& options,
                         double t_start, long steps, bool files,
                         std::vector<std::string> extra_columns)
    : scene_(scene),
      settings_(settings),
      options_(options),
      files_(files && !options.out_dir.empty()),
      t_start_(t_start),
      extra_columns_(std::move(extra_columns)),
      progress_(std::make_unique<Progress>(options, steps)) {
  if (files_) {
    std::error_code error;
    fs::create_directories(options.out_dir, error);
    if (error)
      throw std::runtime_error(options.out_dir + ": cannot create the folder: " + error.message());
    // every output path checked before the first step, not found when the run ends
    std::vector<std::string> outputs{"final_state.csv", "summary.json"};
    if (settings.output.stats) outputs.push_back("stats.csv");
    if (settings.output.stats && !scene.model.actuators.empty()) outputs.push_back("actuators.csv");
    if (settings.output.layer) outputs.insert(outputs.end(), {"layer.json", "layer_height.png"});
    if (settings.output.vtk_every > 0 || settings.output.vtk_interval > 0.0)
      outputs.insert(outputs.end(), {"snapshots.pvd", "contacts.pvd"});
    for (const std::string& name : outputs) requireOutputFile(options.out_dir + "/" + name);
    if (settings.output.stats) {
      stats_ = std::make_unique<StreamedFile>(options.out_dir + "/stats.csv");
      writeStatsHeader(stats_->out, settings.output.timings, extra_columns_);
    }
    if (settings.output.vtk_every > 0 || settings.output.vtk_interval > 0.0)
      vtk_ = std::make_unique<VtkSeries>(scene, options.out_dir);
  }
  summary_.scheme = enumName(settings.scheme.scheme);
  summary_.threads = settings.scheme.threadCount();
  summary_.dt = settings.scheme.h;
  summary_.t_end = settings.t_end;
  summary_.smallest_size = scene.cmodel.smallest_size;
  next_snapshot_ = t_start + settings.output.vtk_interval;
}

RunRecorder::~RunRecorder() = default;

void RunRecorder::snapshot(const SnapshotView& view) {
  if (vtk_) vtk_->write(view);
}

bool RunRecorder::addStep(const StepStats& s, const std::vector<double>& extra) {
  const double h = settings_.scheme.h;
  summary_.steps = s.step;
  summary_.t_reached = s.t;
  summary_.penetration_cumulative += s.penetration_sum;
  summary_.penetration_time_integral += h * s.penetration_sum;
  summary_.penetration_peak = std::max(summary_.penetration_peak, s.penetration_max);
  overlapping_ += s.penetration_count;
  total_.add(s.iterations_stage1 + s.iterations_stage2);
  stage1_.add(s.iterations_stage1);
  stage2_.add(s.iterations_stage2);
  if (options_.keep_iterations)
    summary_.iterations_per_step.push_back(s.iterations_stage1 + s.iterations_stage2);
  summary_.cap_hit_steps += s.cap_hit ? 1 : 0;
  active_sum_ += s.active;
  candidate_sum_ += s.candidates;
  solves_sum_ += s.solves;
  summary_.max_solves = std::max(summary_.max_solves, s.solves);
  summary_.redetection_steps += s.redetections > 0 ? 1 : 0;
  summary_.margin_outrun_steps += s.margin_outrun ? 1 : 0;
  summary_.projection_steps += s.projection_rounds > 0 ? 1 : 0;
  summary_.projection_rounds += s.projection_rounds;
  summary_.projection_iterations += s.projection_iterations;
  summary_.max_active = std::max(summary_.max_active, s.active);
  summary_.updates += s.updates;
  summary_.solve_seconds += s.t_solve;
  if (stats_) {
    appendStatsRow(stats_->out, s, settings_.output.timings, extra);
    stats_->checkEvery(s.step);
  }
  if (!vtk_) return false;
  const OutputSettings& output = settings_.output;
  const bool every = output.vtk_every > 0 && s.step % output.vtk_every == 0;
  const bool interval = output.vtk_interval > 0.0 && s.t >= next_snapshot_ - 1e-9 * h;
  // the next multiple of the interval after t, computed rather than stepped to: an interval
  // far below h would take a loop of (h / interval) additions
  if (interval)
    next_snapshot_ =
        t_start_ +
        output.vtk_interval * (std::floor((s.t + 1e-9 * h - t_start_) / output.vtk_interval) + 1.0);
  return every || interval;
}

void RunRecorder::progress(long step, double t, bool last) {
  progress_->update(step, t, last);
}

void RunRecorder::startClock() {
  wall_start_ = std::chrono::steady_clock::now();
  cpu_start_ = processCpuSeconds();
}

double RunRecorder::cpuSeconds() const {
  return processCpuSeconds() - cpu_start_;
}

void RunRecorder::finish(double energy_final, double t, const VectorX& q, const VectorX& v,
                         double extra_cpu_seconds) {
  RunSummary& summary = summary_;
  summary.cpu_seconds = cpuSeconds() + extra_cpu_seconds;
  summary.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start_).count();
  summary.energy_final = energy_final;
  const double steps = static_cast<double>(summary.steps);
  summary.mean_active = summary.steps > 0 ? active_sum_ / steps : 0.0;
  summary.penetration_mean =
      overlapping_ > 0.0 ? summary.penetration_cumulative / overlapping_ : 0.0;
  if (summary.steps > 0) {
    summary.mean_candidates = candidate_sum_ / steps;
    summary.mean_solves = solves_sum_ / steps;
  }
  summary.iterations = total_.distribution();
  summary.iterations_stage1 = stage1_.distribution();
  summary.iterations_stage2 = stage2_.distribution();
  if (stats_) stats_->finish();
  if (!files_) return;
  // the state the run ended in, exactly (17 digits): to compare runs bit for bit, or to
  // start another from it
  std::ostringstream state;
  state << "vector,index,value\n";
  state << "t,0," << exactNumber(t) << '\n';
  for (Eigen::Index i = 0; i < q.size(); ++i)
    state << "q," << i << ',' << exactNumber(q[i]) << '\n';
  for (Eigen::Index i = 0; i < v.size(); ++i)
    state << "v," << i << ',' << exactNumber(v[i]) << '\n';
  writeFileAtomically(options_.out_dir + "/final_state.csv", state.str());
  // the summary first: it holds the run's figures, whatever happens to the layer's files
  writeSummaryJson(summary, options_.out_dir + "/summary.json");
  if (settings_.output.layer) {
    const LayerMetrics layer = measureLayer(scene_, q, *settings_.output.layer, &v);
    writeLayerJson(layer, *settings_.output.layer, options_.out_dir + "/layer.json");
    writeHeightMapPng(layer, *settings_.output.layer, options_.out_dir + "/layer_height.png");
  }
}

RunSummary runScene(const Scene& scene, const RunSettings& settings, const RunOptions& options) {
  settings.scheme.validate();
  const double t_start = options.start ? options.start->t : 0.0;
  const long steps = stepCount(t_start, settings.t_end, settings.scheme.h);
  RunRecorder recorder(scene, settings, options, t_start, steps, true);
  std::optional<StreamedFile> actuators;
  if (!options.out_dir.empty() && settings.output.stats && !scene.model.actuators.empty()) {
    actuators.emplace(options.out_dir + "/actuators.csv");
    writeActuatorHeader(actuators->out, scene.model);
  }
  ActuatorTally tally(scene.model);

  TimeStepper stepper(scene.model, scene.cmodel, settings.scheme, scene.forces);
  if (options.start)
    stepper.reset(t_start, options.start->q, options.start->v);
  else
    stepper.reset(0.0, scene.q0, scene.v0);

  RunSummary& summary = recorder.summary();
  summary.margin_verified =
      scene.cmodel.settings.verify_margin && settings.scheme.normal_law != NormalLaw::Vel;
  summary.energy_initial = stepper.energy();
  recorder.snapshot(snapshotOf(stepper));

  recorder.startClock();
  for (long k = 0; k < steps; ++k) {
    // a step whose state ran away ends the run as a signal does: stats.csv and the summary
    // whole up to the step before, final_state.csv the state it ran away to (for inspection);
    // the command then fails
    try {
      stepper.step();
    } catch (const RunawayError& e) {
      summary.failure = e.what();  // steps and t_reached stay those of the last whole step
      break;
    }
    const StepStats& s = stepper.stats();
    if (!stepper.q().allFinite() || !stepper.v().allFinite())
      throw std::runtime_error("step " + std::to_string(s.step) + " (t = " + exactNumber(s.t) +
                               "): the state is no longer finite");
    if (divergedSolve(s)) throw std::runtime_error(divergedSolveMessage(s));
    if (recorder.addStep(s)) recorder.snapshot(snapshotOf(stepper));
    tally.add(scene.model, stepper);
    if (actuators) {
      appendActuatorRow(actuators->out, scene.model, stepper);
      actuators->checkEvery(s.step);
    }
    const bool stopping = options.stop != nullptr && options.stop->load();
    recorder.progress(s.step, s.t, k + 1 == steps || stopping);
    if (stopping) {
      summary.interrupted = true;
      break;
    }
  }
  summary.actuators = tally.summary(scene.model);
  if (actuators) actuators->finish();
  recorder.finish(stepper.energy(), stepper.time(), stepper.q(), stepper.v());
  return summary;
}

}  // namespace sweep
