#pragma once
// `sweep bench`: run time against penetration error over time steps and schemes, the
// Pareto view of the seed's Figure 2. Writes bench.csv, each run's stats.csv and
// summary.json under runs/, and the figures (scripts/plot_bench.py, matplotlib).
#include <atomic>
#include <iosfwd>
#include <string>
#include <vector>

#include "apps/sweep/scene_file.hpp"

namespace sweep {

struct BenchOptions {
  std::vector<double> steps;         // h values
  std::vector<std::string> schemes;  // scheme names
  int repeat = 1;                    // runs per point; the least CPU time counts
  std::string out_dir = "bench";
  bool no_plots = false;
  std::ostream* log = nullptr;
  const std::atomic<bool>* stop = nullptr;
};

// Returns the process exit code (0, or 1 when the figures could not be made).
int runBench(const SceneFile& file, const Scene& scene, const BenchOptions& options,
             std::ostream& out);

// The plotting script: $SWEEP_PLOT_SCRIPT, else the source tree's, else the installed one.
std::string plotScriptPath();

}  // namespace sweep
