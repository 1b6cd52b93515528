#include "apps/sweep/run.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <ostream>
#include <sstream>
#include <stdexcept>

#include "apps/sweep/layer_output.hpp"
#include "apps/sweep/vtk_writer.hpp"
#include "framework/error.hpp"

namespace sweep {

namespace {

namespace fs = std::filesystem;

double processCpuSeconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

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

const char* kStatsHeader =
    "step,t,n_candidates,n_active,iters_stage1,iters_stage2,residual,cap_hit,pen_max,pen_sum,"
    "pen_count,kinetic,potential,work_normal,work_tangent";
const char* kTimingHeader = ",t_detect,t_assemble,t_solve,t_update";

void appendStatsRow(std::ostream& out, const StepStats& s, bool timings) {
  out << s.step << ',' << exactNumber(s.t) << ',' << s.candidates << ',' << s.active << ','
      << s.iterations_stage1 << ',' << s.iterations_stage2 << ',' << exactNumber(s.residual) << ','
      << (s.cap_hit ? 1 : 0) << ',' << exactNumber(s.penetration_max) << ','
      << exactNumber(s.penetration_sum) << ',' << s.penetration_count << ','
      << exactNumber(s.kinetic) << ',' << exactNumber(s.potential) << ','
      << exactNumber(s.work_normal) << ',' << exactNumber(s.work_tangent);
  if (timings)
    out << ',' << exactNumber(s.t_detect) << ',' << exactNumber(s.t_assemble) << ','
        << exactNumber(s.t_solve) << ',' << exactNumber(s.t_update);
  out << '\n';
}

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

}  // namespace

std::string exactNumber(double x) {
  std::ostringstream s;
  s << std::setprecision(17) << x;
  return s.str();
}

Distribution distributionOf(std::vector<int> values) {
  Distribution d;
  if (values.empty()) return d;
  std::sort(values.begin(), values.end());
  double sum = 0.0;
  for (int v : values) sum += v;
  d.mean = sum / static_cast<double>(values.size());
  // nearest-rank percentiles
  auto rank = [&](double p) {
    const auto k = static_cast<std::size_t>(std::ceil(p * static_cast<double>(values.size())));
    return static_cast<double>(values[std::clamp<std::size_t>(k, 1, values.size()) - 1]);
  };
  d.p50 = rank(0.50);
  d.p95 = rank(0.95);
  d.p99 = rank(0.99);
  d.max = values.back();
  return d;
}

void writeFileAtomically(const std::string& path, const std::string& text) {
  const std::string partial = path + ".partial";
  {
    std::ofstream out(partial, std::ios::binary);
    out << text;
    out.flush();
    if (!out.good()) throw std::runtime_error(partial + ": cannot write (disk full?)");
  }
  std::error_code error;
  fs::rename(partial, path, error);
  if (error) throw std::runtime_error(path + ": cannot rename into place: " + error.message());
}

SavedState readSavedState(const std::string& path, const Model& model) {
  std::error_code error;
  if (!fs::is_regular_file(path, error))
    throw InputError(path + ": saved state does not exist or is not a regular file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open the saved state");
  SavedState state;
  state.q = VectorX::Constant(model.nq, std::nan(""));
  state.v = VectorX::Constant(model.nv, std::nan(""));
  std::vector<char> seen_q(model.nq, 0), seen_v(model.nv, 0);
  char seen_t = 0;
  std::string line;
  int number = 0;
  auto fail = [&](const std::string& what) {
    throw InputError(path + ":" + std::to_string(number) + ": " + what);
  };
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (number == 1) {
      if (line != "vector,index,value")
        fail("expected the header 'vector,index,value' of a final_state.csv, got '" +
             line.substr(0, 80) + "'");
      continue;
    }
    if (line.empty()) continue;
    std::istringstream row(line);
    std::string kind, index_text, value_text;
    if (!std::getline(row, kind, ',') || !std::getline(row, index_text, ',') ||
        !std::getline(row, value_text))
      fail("expected 'vector,index,value', got '" + line.substr(0, 80) + "'");
    std::size_t used = 0;
    long index = -1;
    double value = 0.0;
    try {
      index = std::stol(index_text, &used);
      if (used != index_text.size()) index = -1;
      value = std::stod(value_text, &used);
      if (used != value_text.size()) fail("value '" + value_text + "' is not a number");
    } catch (const std::logic_error&) {
      fail("'" + line.substr(0, 80) + "' is not 'vector,index,number'");
    }
    if (!std::isfinite(value))
      fail(kind + "[" + index_text + "] = " + value_text + " is not finite");
    const long size = kind == "q" ? model.nq : kind == "v" ? model.nv : kind == "t" ? 1 : -1;
    if (size < 0) fail("vector '" + kind + "' is none of t, q, v");
    if (index < 0 || index >= size)
      fail(kind + " index " + index_text + " is out of range [0, " + std::to_string(size) +
           ") for this scene (nq = " + std::to_string(model.nq) +
           ", nv = " + std::to_string(model.nv) + ")");
    char& seen = kind == "t" ? seen_t : kind == "q" ? seen_q[index] : seen_v[index];
    if (seen) fail(kind + "[" + index_text + "] is given twice");
    seen = 1;
    if (kind == "t")
      state.t = value;
    else if (kind == "q")
      state.q[index] = value;
    else
      state.v[index] = value;
  }
  if (!seen_t)
    throw InputError(path +
                     ": no 't' row (the time of the state; written by sweep 0.1.0 runs "
                     "since 2026-11-22: add a row 't,0,TIME' after the header)");
  for (int i = 0; i < model.nq; ++i)
    if (!seen_q[i])
      throw InputError(path + ": q[" + std::to_string(i) + "] is missing (the scene has nq = " +
                       std::to_string(model.nq) + ": a state of another scene?)");
  for (int i = 0; i < model.nv; ++i)
    if (!seen_v[i])
      throw InputError(path + ": v[" + std::to_string(i) + "] is missing (the scene has nv = " +
                       std::to_string(model.nv) + ": a state of another scene?)");
  return state;
}

RunSummary runScene(const Scene& scene, const RunSettings& settings, const RunOptions& options) {
  settings.scheme.validate();
  if (!(settings.t_end > 0.0) || !std::isfinite(settings.t_end))
    throw InputError("t_end must be > 0, got " + exactNumber(settings.t_end));
  const double h = settings.scheme.h;
  const double t_start = options.start ? options.start->t : 0.0;
  if (options.start && !(settings.t_end > t_start + 0.5 * h))
    throw InputError("t_end = " + exactNumber(settings.t_end) +
                     " s leaves no step after the saved state's t = " + exactNumber(t_start) +
                     " s");
  const long steps = std::max(1L, std::lround((settings.t_end - t_start) / h));
  if (steps > 2000000000L)
    throw InputError("(t_end - t_start) / dt = " + exactNumber((settings.t_end - t_start) / h) +
                     " steps is too many");

  const bool files = !options.out_dir.empty();
  if (files) {
    std::error_code error;
    fs::create_directories(options.out_dir, error);
    if (error)
      throw std::runtime_error(options.out_dir + ": cannot create the folder: " + error.message());
  }
  // stats.csv grows step by step under its temporary name; renamed when the run ends
  const std::string stats_path = options.out_dir + "/stats.csv";
  std::ofstream stats;
  if (files && settings.output.stats) {
    stats.open(stats_path + ".partial", std::ios::binary);
    if (!stats) throw std::runtime_error(stats_path + ".partial: cannot open for writing");
    stats << kStatsHeader << (settings.output.timings ? kTimingHeader : "") << '\n';
  }
  std::unique_ptr<VtkSeries> vtk;
  const bool snapshots = settings.output.vtk_every > 0 || settings.output.vtk_interval > 0.0;
  if (files && snapshots) vtk = std::make_unique<VtkSeries>(scene, options.out_dir);

  TimeStepper stepper(scene.model, scene.cmodel, settings.scheme, scene.forces);
  if (options.start)
    stepper.reset(t_start, options.start->q, options.start->v);
  else
    stepper.reset(0.0, scene.q0, scene.v0);

  RunSummary summary;
  summary.scheme = schemeName(settings.scheme.scheme);
  summary.dt = h;
  summary.t_end = settings.t_end;
  summary.margin_verified =
      scene.cmodel.settings.verify_margin && settings.scheme.normal_law != NormalLaw::Vel;
  summary.energy_initial = stepper.energy();
  std::vector<int> total, stage1, stage2;
  total.reserve(steps);
  stage1.reserve(steps);
  stage2.reserve(steps);
  double active_sum = 0.0, candidate_sum = 0.0, solves_sum = 0.0;
  double next_snapshot = 0.0;
  if (vtk) {
    vtk->write(stepper);
    next_snapshot = t_start + settings.output.vtk_interval;
  }

  Progress progress(options, steps);
  const auto wall_start = std::chrono::steady_clock::now();
  const double cpu_start = processCpuSeconds();
  for (long k = 0; k < steps; ++k) {
    const StepStats& s = stepper.step();
    if (!stepper.q().allFinite() || !stepper.v().allFinite())
      throw std::runtime_error("step " + std::to_string(s.step) + " (t = " + exactNumber(s.t) +
                               "): the state is no longer finite");
    summary.steps = s.step;
    summary.t_reached = s.t;
    summary.penetration_cumulative += s.penetration_sum;
    summary.penetration_time_integral += h * s.penetration_sum;
    summary.penetration_peak = std::max(summary.penetration_peak, s.penetration_max);
    total.push_back(s.iterations_stage1 + s.iterations_stage2);
    stage1.push_back(s.iterations_stage1);
    stage2.push_back(s.iterations_stage2);
    summary.cap_hit_steps += s.cap_hit ? 1 : 0;
    active_sum += s.active;
    candidate_sum += s.candidates;
    solves_sum += s.solves;
    summary.max_solves = std::max(summary.max_solves, s.solves);
    summary.redetection_steps += s.redetections > 0 ? 1 : 0;
    summary.margin_outrun_steps += s.margin_outrun ? 1 : 0;
    summary.max_active = std::max(summary.max_active, s.active);
    summary.updates += s.updates;
    summary.solve_seconds += s.t_solve;
    if (stats.is_open()) {
      appendStatsRow(stats, s, settings.output.timings);
      // a full disk stops the run at once rather than computing results nobody gets
      if (s.step % 1024 == 0 && !stats.flush())
        throw std::runtime_error(stats_path + ".partial: cannot write at step " +
                                 std::to_string(s.step) + " (disk full?)");
    }
    if (vtk) {
      const bool every = settings.output.vtk_every > 0 && s.step % settings.output.vtk_every == 0;
      const bool interval = settings.output.vtk_interval > 0.0 && s.t >= next_snapshot - 1e-9 * h;
      if (interval)
        while (next_snapshot <= s.t + 1e-9 * h) next_snapshot += settings.output.vtk_interval;
      if (every || interval) vtk->write(stepper);
    }
    const bool stopping = options.stop != nullptr && options.stop->load();
    progress.update(s.step, s.t, k + 1 == steps || stopping);
    if (stopping) {
      summary.interrupted = true;
      break;
    }
  }
  summary.cpu_seconds = processCpuSeconds() - cpu_start;
  summary.wall_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  summary.energy_final = stepper.energy();
  summary.mean_active = summary.steps > 0 ? active_sum / static_cast<double>(summary.steps) : 0.0;
  if (summary.steps > 0) {
    summary.mean_candidates = candidate_sum / static_cast<double>(summary.steps);
    summary.mean_solves = solves_sum / static_cast<double>(summary.steps);
  }
  if (options.keep_iterations) summary.iterations_per_step = total;
  summary.iterations = distributionOf(std::move(total));
  summary.iterations_stage1 = distributionOf(std::move(stage1));
  summary.iterations_stage2 = distributionOf(std::move(stage2));

  if (stats.is_open()) {
    stats.close();
    if (!stats) throw std::runtime_error(stats_path + ": cannot write (disk full?)");
    std::error_code error;
    fs::rename(stats_path + ".partial", stats_path, error);
    if (error) throw std::runtime_error(stats_path + ": cannot rename into place");
  }
  if (files) {
    // the state the run ended in, exactly (17 digits): to compare runs bit for bit, or to
    // start another from it
    std::ostringstream state;
    state << "vector,index,value\n";
    state << "t,0," << exactNumber(stepper.time()) << '\n';
    for (Eigen::Index i = 0; i < stepper.q().size(); ++i)
      state << "q," << i << ',' << exactNumber(stepper.q()[i]) << '\n';
    for (Eigen::Index i = 0; i < stepper.v().size(); ++i)
      state << "v," << i << ',' << exactNumber(stepper.v()[i]) << '\n';
    writeFileAtomically(options.out_dir + "/final_state.csv", state.str());
    if (settings.output.layer) {
      const LayerMetrics layer =
          measureLayer(scene, stepper.q(), *settings.output.layer, &stepper.v());
      writeLayerJson(layer, *settings.output.layer, options.out_dir + "/layer.json");
      writeHeightMapPng(layer, *settings.output.layer, options.out_dir + "/layer_height.png");
    }
    writeSummaryJson(summary, options.out_dir + "/summary.json");
  }
  return summary;
}

void writeSummaryJson(const RunSummary& s, const std::string& path) {
  auto distribution = [](const Distribution& d) {
    return "{\"mean\": " + exactNumber(d.mean) + ", \"p50\": " + exactNumber(d.p50) +
           ", \"p95\": " + exactNumber(d.p95) + ", \"p99\": " + exactNumber(d.p99) +
           ", \"max\": " + exactNumber(d.max) + "}";
  };
  std::ostringstream j;
  j << "{\n"
    << "  \"scheme\": \"" << s.scheme << "\",\n"
    << "  \"dt\": " << exactNumber(s.dt) << ",\n"
    << "  \"t_end\": " << exactNumber(s.t_end) << ",\n"
    << "  \"t_reached\": " << exactNumber(s.t_reached) << ",\n"
    << "  \"steps\": " << s.steps << ",\n"
    << "  \"interrupted\": " << (s.interrupted ? "true" : "false") << ",\n"
    << "  \"cpu_seconds\": " << exactNumber(s.cpu_seconds) << ",\n"
    << "  \"wall_seconds\": " << exactNumber(s.wall_seconds) << ",\n"
    << "  \"penetration\": {\"cumulative\": " << exactNumber(s.penetration_cumulative)
    << ", \"time_integral\": " << exactNumber(s.penetration_time_integral)
    << ", \"peak\": " << exactNumber(s.penetration_peak) << "},\n"
    << "  \"iterations\": {\"mean\": " << exactNumber(s.iterations.mean)
    << ", \"p50\": " << exactNumber(s.iterations.p50)
    << ", \"p95\": " << exactNumber(s.iterations.p95)
    << ", \"p99\": " << exactNumber(s.iterations.p99)
    << ", \"max\": " << exactNumber(s.iterations.max) << ", \"cap_hit_steps\": " << s.cap_hit_steps
    << ",\n                 \"stage1\": " << distribution(s.iterations_stage1)
    << ",\n                 \"stage2\": " << distribution(s.iterations_stage2) << "},\n"
    << "  \"contacts\": {\"mean_active\": " << exactNumber(s.mean_active)
    << ", \"max_active\": " << s.max_active
    << ", \"mean_candidates\": " << exactNumber(s.mean_candidates)
    << ", \"mean_solves\": " << exactNumber(s.mean_solves) << ", \"max_solves\": " << s.max_solves
    << ", \"redetection_steps\": " << s.redetection_steps
    << ", \"margin_outrun_steps\": " << s.margin_outrun_steps << "},\n"
    << "  \"solver\": {\"updates\": " << s.updates
    << ", \"solve_seconds\": " << exactNumber(s.solve_seconds) << ", \"ns_per_update\": "
    << exactNumber(s.updates > 0 ? 1e9 * s.solve_seconds / static_cast<double>(s.updates) : 0.0)
    << "},\n"
    << "  \"energy\": {\"initial\": " << exactNumber(s.energy_initial)
    << ", \"final\": " << exactNumber(s.energy_final) << "}\n"
    << "}\n";
  writeFileAtomically(path, j.str());
}

}  // namespace sweep
