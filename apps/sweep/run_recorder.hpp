#pragma once
// What a run records, step by step, whoever steps it: the single process (runScene) or rank 0
// of several (runSceneOnRanks). The summary's sums and distributions, stats.csv, the VTK
// snapshots, the progress line, and at the end final_state.csv, summary.json and the layer's
// files. Only the process that writes the files constructs it with `files` true.
#include <chrono>
#include <memory>
#include <string>
#include <vector>

#include "apps/sweep/run.hpp"
#include "apps/sweep/vtk_writer.hpp"

namespace sweep {

struct StreamedFile;
class Progress;

class RunRecorder {
 public:
  // Checks every output path and opens stats.csv (when files and options.out_dir are set).
  // extra_columns: names appended to stats.csv's columns; addStep gives their values.
  RunRecorder(const Scene& scene, const RunSettings& settings, const RunOptions& options,
              double t_start, long steps, bool files, std::vector<std::string> extra_columns = {});
  ~RunRecorder();
  RunRecorder(const RunRecorder&) = delete;
  RunRecorder& operator=(const RunRecorder&) = delete;

  RunSummary& summary() { return summary_; }
  bool snapshots() const { return vtk_ != nullptr; }
  void snapshot(const SnapshotView& view);  // nothing without snapshots
  // One step's statistics: the summary's sums, stats.csv's row. True when a snapshot is due.
  bool addStep(const StepStats& s, const std::vector<double>& extra = {});
  void progress(long step, double t, bool last);
  // Before the first step: the start of the run's CPU and wall time.
  void startClock();
  // After the last step: the time since startClock, the summary's means and distributions;
  // stats.csv renamed into place; final_state.csv, summary.json and the layer's files written.
  // extra_cpu_seconds: CPU time spent elsewhere in the run (the other ranks').
  void finish(double energy_final, double t, const VectorX& q, const VectorX& v,
              double extra_cpu_seconds = 0.0);
  // This process's CPU time since startClock.
  double cpuSeconds() const;

 private:
  const Scene& scene_;
  const RunSettings& settings_;
  const RunOptions& options_;
  bool files_ = false;
  double t_start_ = 0.0;
  std::vector<std::string> extra_columns_;
  std::unique_ptr<Progress> progress_;
  std::unique_ptr<StreamedFile> stats_;
  std::unique_ptr<VtkSeries> vtk_;
  RunSummary summary_;
  // counts of each iteration number, not a value per step: a run of 10^9 steps must not hold
  // (or reserve) 10^9 of them
  IterationHistogram total_, stage1_, stage2_;
  double active_sum_ = 0.0, candidate_sum_ = 0.0, solves_sum_ = 0.0;
  double overlapping_ = 0.0;  // contacts overlapping at step ends, summed over steps
  double next_snapshot_ = 0.0;
  double cpu_start_ = 0.0;
  std::chrono::steady_clock::time_point wall_start_;
};

}  // namespace sweep
