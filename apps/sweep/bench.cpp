#include "apps/sweep/bench.hpp"

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <ostream>
#include <sstream>

#include "apps/sweep/run.hpp"
#include "framework/error.hpp"

namespace sweep {

namespace {

// "1e-4" rather than "0.0001" in folder names
std::string shortNumber(double x) {
  std::ostringstream s;
  s << std::setprecision(6) << x;
  return s.str();
}

// Quotes a path for /bin/sh.
std::string shellQuote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += (c == '\'') ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

}  // namespace

std::string plotScriptPath() {
  if (const char* env = std::getenv("SWEEP_PLOT_SCRIPT")) return env;
  for (const char* candidate :
       {SWEEP_SOURCE_DIR "/scripts/plot_bench.py", SWEEP_INSTALL_DATADIR "/scripts/plot_bench.py"})
    if (std::filesystem::exists(candidate)) return candidate;
  return SWEEP_SOURCE_DIR "/scripts/plot_bench.py";
}

int runBench(const SceneFile& file, const Scene& scene, const BenchOptions& options,
             std::ostream& out) {
  if (options.steps.empty()) throw InputError("--dt: give at least one time step");
  for (double h : options.steps) {
    if (!(h > 0.0) || !std::isfinite(h))
      throw InputError("--dt: every step must be > 0, got " + exactNumber(h));
    // every point is checked before the first runs: a bad last point must not cost the others
    try {
      stepCount(0.0, file.run.t_end, h);
    } catch (const InputError& e) {
      throw InputError(file.path + ": --dt " + exactNumber(h) + ": " + e.what());
    }
  }
  // each point has its own folder (runs/SCHEME_dtSTEP) and row: two steps that name the same
  // folder would overwrite each other's run
  for (std::size_t i = 0; i < options.steps.size(); ++i)
    for (std::size_t j = 0; j < i; ++j)
      if (shortNumber(options.steps[i]) == shortNumber(options.steps[j]))
        throw InputError("--dt: " + exactNumber(options.steps[j]) + " and " +
                         exactNumber(options.steps[i]) + " are the same point (runs/*_dt" +
                         shortNumber(options.steps[i]) + "); give each step once");
  if (options.repeat < 1) throw InputError("--repeat: must be >= 1");
  std::vector<Scheme> schemes;
  for (const std::string& name : options.schemes) schemes.push_back(schemeFromName(name));

  requireOutputFile(options.out_dir + "/bench.csv");  // before the first run, not after
  std::filesystem::create_directories(options.out_dir + "/runs");
  std::ostringstream csv;
  csv << "scheme,dt,steps,cpu_seconds,penetration_cumulative,penetration_time_integral,"
         "penetration_peak,iters_mean,iters_p95,iters_max,cap_hit_fraction,"
         "iters_stage1_p95,iters_stage2_p95,ns_per_update\n";
  bool interrupted = false;
  for (Scheme scheme : schemes) {
    for (double h : options.steps) {
      RunSettings settings = file.run;
      settings.scheme.scheme = scheme;
      settings.scheme.h = h;
      settings.output.vtk_every = 0;
      settings.output.vtk_interval = 0.0;
      RunSummary best;
      for (int r = 0; r < options.repeat && !interrupted; ++r) {
        RunOptions run;
        // the first run keeps its per-step record; repeats only time
        if (r == 0)
          run.out_dir = options.out_dir + "/runs/" + enumName(scheme) + "_dt" + shortNumber(h);
        run.stop = options.stop;
        const RunSummary s = runScene(scene, settings, run);
        interrupted = s.interrupted;
        if (r == 0 || s.cpu_seconds < best.cpu_seconds) best = s;
      }
      if (interrupted) break;
      csv << best.scheme << ',' << exactNumber(h) << ',' << best.steps << ','
          << exactNumber(best.cpu_seconds) << ',' << exactNumber(best.penetration_cumulative) << ','
          << exactNumber(best.penetration_time_integral) << ','
          << exactNumber(best.penetration_peak) << ',' << exactNumber(best.iterations.mean) << ','
          << exactNumber(best.iterations.p95) << ',' << exactNumber(best.iterations.max) << ','
          << exactNumber(static_cast<double>(best.cap_hit_steps) / static_cast<double>(best.steps))
          << ',' << exactNumber(best.iterations_stage1.p95) << ','
          << exactNumber(best.iterations_stage2.p95) << ','
          << exactNumber(best.updates > 0
                             ? 1e9 * best.solve_seconds / static_cast<double>(best.updates)
                             : 0.0)
          << '\n';
      if (options.log != nullptr)
        *options.log << std::setprecision(4) << best.scheme << " h = " << h << ": cpu "
                     << best.cpu_seconds << " s, penetration " << best.penetration_cumulative
                     << " m, iterations p95 " << best.iterations.p95 << ", cap hit in "
                     << best.cap_hit_steps << "/" << best.steps << " steps\n";
    }
    if (interrupted) break;
  }
  const std::string csv_path = options.out_dir + "/bench.csv";
  writeFileAtomically(csv_path, csv.str());
  out << "wrote " << csv_path << (interrupted ? " (interrupted: finished points only)" : "")
      << "\n";
  if (options.no_plots || interrupted) return interrupted ? 130 : 0;

  const std::string command =
      "/usr/bin/python3 " + shellQuote(plotScriptPath()) + " " + shellQuote(options.out_dir);
  const int status = std::system(command.c_str());
  if (status != 0) {
    out << "sweep: the figures failed (" << command << " exited with " << status
        << "); bench.csv is complete\n";
    return 1;
  }
  return 0;
}

}  // namespace sweep
