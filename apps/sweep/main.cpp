// `sweep`: runs scene files. Subcommands: run, bench, check, export (docs/cli.md).
// Exit codes: 0 success, 2 bad input, 1 runtime failure.
#include <unistd.h>
#include <cmath>

#include <CLI/CLI.hpp>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <optional>
#include <sstream>
#include <thread>

#include "apps/sweep/bench.hpp"
#include "apps/sweep/run.hpp"
#include "apps/sweep/scene_file.hpp"
#include "apps/sweep/signals.hpp"
#include "apps/sweep/viewer.hpp"
#include "framework/error.hpp"
#ifdef SWEEP_RANKS
#include "apps/sweep/ranks_run.hpp"
#endif

namespace {

// `sweep check` and the head of `sweep run`: what the scene is and what the pipeline skips.
void describeScene(const sweep::SceneFile& file, const sweep::Scene& scene, std::ostream& out) {
  const sweep::Model& model = scene.model;
  int constant = 0;
  for (const sweep::Component& c : model.components) constant += c.constant_mass ? 1 : 0;
  out << file.path << ": " << file.spec.dimension << "D scene, " << model.bodies.size()
      << " bodies in " << model.components.size() << " components (" << constant
      << " with a constant mass block, never rebuilt), " << model.driven_bodies.size()
      << " driven, nq = " << model.nq << ", nv = " << model.nv << "\n";
  out << "  " << sweep::describe(scene.cmodel) << "\n";
  for (const std::string& note : model.notes) out << "  note: " << note << "\n";
  if (!model.actuators.empty()) {
    out << "  actuators (implicit servos, torque limits):";
    for (const sweep::JointActuator& a : model.actuators) {
      out << " " << a.joint << " (" << (a.servo() ? "servo" : "motor");
      if (std::isfinite(a.max_torque)) out << ", |tau| <= " << a.max_torque;
      out << ")";
    }
    out << "\n";
  }
  const sweep::SchemeSettings& s = file.run.scheme;
  // auto as what it resolves to here (stage_solvers.cpp, convex_stages.cpp): Newton on 2D
  // problems; in 3D NLGS with NNCG where every row joins free bodies (packed rows), else MPRGP /
  // APGD
  bool free_bodies_only =
      s.packed_rows && model.limits.empty() && model.systems.empty() && model.constraints.empty();
  for (const sweep::Body& body : model.bodies)
    free_bodies_only =
        free_bodies_only && body.parent < 0 && body.joint.type == sweep::JointType::Floating;
  auto stageSolverShown = [&](sweep::StageSolver solver) {
    if (solver != sweep::StageSolver::Auto) return std::string(sweep::enumName(solver));
    if (file.spec.dimension == 2) return std::string("newton (auto)");
    return std::string(free_bodies_only ? "nlgs with nncg (auto)" : "mprgp (auto)");
  };
  out << "  scheme: " << sweep::enumName(s.scheme) << ", h = " << s.h
      << " s, t_end = " << file.run.t_end << " s, normal law " << sweep::enumName(s.normal_law);
  if (s.scheme == sweep::Scheme::CatchingUp)
    out << ", tangents " << sweep::enumName(s.friction.tangents)
        << (s.friction.tangents == sweep::TangentMode::Global
                ? std::string(" (open contacts ") + sweep::enumName(s.friction.open_contacts) + ")"
                : std::string())
        << ", threshold " << sweep::enumName(s.friction.threshold) << ", stage solvers "
        << stageSolverShown(s.normal_stage.solver) << " + "
        << stageSolverShown(s.friction_stage.solver) << ", caps " << s.normal_stage.max_iterations
        << " + " << s.friction_stage.max_iterations;
  else
    out << ", cap " << s.coulomb.max_iterations;
  const bool catching_up = s.scheme == sweep::Scheme::CatchingUp;
  out << ", tolerance " << (catching_up ? s.normal_stage.tolerance : s.coulomb.tolerance);
  const bool nncg = catching_up ? s.normal_stage.acceleration == sweep::NlgsAcceleration::Nncg ||
                                      s.friction_stage.acceleration == sweep::NlgsAcceleration::Nncg
                                : s.coulomb.acceleration == sweep::NlgsAcceleration::Nncg;
  if (nncg) out << ", NNCG sweeps";
  if (s.projection.max_rounds > 0)
    out << ", position projection (up to " << s.projection.max_rounds << " rounds, tolerance "
        << s.projection.tolerance << " of the smallest size)";
  out << ", threads " << s.threadCount();
  if (!s.packed_rows) out << ", generic rows";
  if (s.compact_sphere_rows)
    out << (*s.compact_sphere_rows ? ", compact sphere rows" : ", body-form sphere rows");
  out << "\n";
}

#ifndef SWEEP_RANKS
// Started by mpirun / mpiexec as one of several processes in a build without MPI, every one
// would run the whole scene and write the same files: refused. The launchers name the process
// count in the environment (Open MPI, MPICH's Hydra, MVAPICH, Slurm's PMI).
void refuseSeveralRanks() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "MV2_COMM_WORLD_SIZE"}) {
    const char* value = std::getenv(name);
    if (value == nullptr || std::atol(value) <= 1) continue;
    throw sweep::InputError(std::string("started as one of ") + value + " MPI processes (" + name +
                            "=" + value +
                            "): this sweep was built without MPI and runs in one process; start "
                            "one and use its cores with --threads N");
  }
}

#endif

// Under several ranks each rank's threads share the node's cores: `threads: 0` (every core)
// becomes the cores over the ranks on this node (Open MPI names them; otherwise all ranks).
int threadsPerRank(int ranks) {
  int on_node = ranks;
  if (const char* local = std::getenv("OMPI_COMM_WORLD_LOCAL_SIZE"))
    on_node = std::max(1, std::atoi(local));
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  return std::max(1, cores / on_node);
}

void printSummary(const sweep::RunSummary& s, const std::string& out_dir, std::ostream& out) {
  out << std::setprecision(4);
  // a length as a share of the smallest moving shape's radius or half extent
  auto ofSmallest = [&](double length) {
    if (!(s.smallest_size > 0.0)) return std::string();
    std::ostringstream text;
    text << std::setprecision(3) << " (" << 100.0 * length / s.smallest_size
         << " % of the smallest size, " << s.smallest_size << " m)";
    return text.str();
  };
  out << "\n"
      << s.scheme << (s.interrupted ? " (INTERRUPTED)" : "")
      << (s.failure.empty() ? "" : " (RAN AWAY)") << ": " << s.steps << " steps of " << s.dt
      << " s to t = " << s.t_reached << " s\n"
      << "  cpu " << s.cpu_seconds << " s, wall " << s.wall_seconds << " s ("
      << (s.wall_seconds > 0 ? s.steps / s.wall_seconds : 0.0) << " steps/s)\n"
      << "  iterations per step: mean " << s.iterations.mean << ", p50 " << s.iterations.p50
      << ", p95 " << s.iterations.p95 << ", max " << s.iterations.max << "; cap hit in "
      << s.cap_hit_steps << " steps\n"
      << "  penetration: peak " << s.penetration_peak << " m" << ofSmallest(s.penetration_peak)
      << ", mean per overlapping contact " << s.penetration_mean << " m"
      << ofSmallest(s.penetration_mean) << "; cumulative " << s.penetration_cumulative
      << " m, time integral " << s.penetration_time_integral << " m s\n"
      << "  active contacts: mean " << s.mean_active << ", max " << s.max_active << "\n"
      << "  energy: " << s.energy_initial << " J -> " << s.energy_final << " J\n";
  if (s.max_solves > 1)
    out << "  candidate screening: " << s.mean_candidates << " candidates, " << s.mean_solves
        << " solves per step (max " << s.max_solves << ")\n";
  if (s.margin_verified)
    out << "  detection margin checked: " << s.redetection_steps << " steps detected again, "
        << s.margin_outrun_steps << " outran the margin after "
        << sweep::TimeStepper::kMaxRedetections + 1 << " detections\n";
  if (s.projection_steps > 0)
    out << "  position projection: " << s.projection_steps << " steps projected, "
        << s.projection_rounds << " rounds, " << s.projection_iterations << " solver iterations\n";
  out << sweep::saturationNote(s.actuators, s.steps);
  if (s.updates > 0)
    out << "  solver: " << s.updates << " local solves, "
        << 1e9 * s.solve_seconds / static_cast<double>(s.updates) << " ns each\n";
  if (s.ranks > 1)
    out << "  ranks: " << s.ranks << ", " << s.bytes_per_step << " bytes sent and "
        << s.shared_bodies_per_step << " bodies shared per step, work imbalance up to "
        << s.imbalance_max << "\n";
  if (!out_dir.empty()) out << "  results in " << out_dir << "/\n";
}

}  // namespace

static int runCommand(int argc, char** argv) {
  // first: a signal that comes while the command line is read is still honoured
  sweep::installStopSignals();
  CLI::App app{"Sweep: nonsmooth contact dynamics of multibody systems"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "sweep 0.1.0");

  std::string scene_path, out_dir, scheme_name;
  std::vector<std::string> overrides, settings_files;
  double dt = 0.0, t_end = 0.0;
  bool quiet = false;
  auto addSceneOptions = [&](CLI::App* command) {
    command->add_option("scene", scene_path, "scene file (YAML)")->required();
    command->add_option("--set", overrides, "override a scene field: path=value (repeatable)");
    command->add_option("--set-file", settings_files,
                        "override scene fields from a YAML map of path: value entries, "
                        "before any --set (repeatable)");
  };

  CLI::App* run = app.add_subcommand("run", "run a scene and write its results");
  addSceneOptions(run);
  run->add_option("--scheme", scheme_name, "moreau-jean or catching-up");
  run->add_option("--dt", dt, "time step h (s)");
  run->add_option("--t-end", t_end, "end time (s)");
  run->add_option("--out", out_dir, "output folder")->default_val("results");
  run->add_flag("--quiet", quiet,
                "no progress bar; the description and the summary are still printed");
  int threads = 0;
  run->add_option("--threads", threads, "threads (0: every core; default: scheme.threads, 0)");
  // the row storages are a benchmark's ablation, not a scene's: every choice gives the same
  // results up to round-off (docs/architecture.md, "Contact rows in two forms")
  std::string row_storage = "auto";
  const auto row_storages = CLI::IsMember({"auto", "generic", "body-form", "compact"});
  run->add_option("--row-storage", row_storage,
                  "contact rows for benchmarks: auto, generic (no packed rows), body-form or "
                  "compact (3D spheres' rows); the same results up to round-off")
      ->check(row_storages);
#ifdef SWEEP_RANKS
  // a finite number >= 0 (CLI::NonNegativeNumber lets nan through)
  const CLI::Validator finite_non_negative(
      [](std::string& text) {
        char* end = nullptr;
        const double value = std::strtod(text.c_str(), &end);
        if (end == text.c_str() || *end != '\0' || !std::isfinite(value) || value < 0.0)
          return "must be a finite number >= 0, got " + text;
        return std::string();
      },
      "NUMBER >= 0");
  sweep::DistributedSettings distributed;
  run->add_option("--rebalance-every", distributed.rebalance_interval,
                  "on MPI ranks: steps between two checks of the balance (0: balanced at the "
                  "start only)")
      ->check(finite_non_negative)
      ->capture_default_str();
  run->add_option("--rebalance-above", distributed.rebalance_above,
                  "on MPI ranks: cut again by work at a check when the most work on one rank "
                  "exceeds this times the mean (0: at every check)")
      ->check(finite_non_negative)
      ->capture_default_str();
#endif
  std::string initial_state;
  run->add_option("--initial-state", initial_state,
                  "start from a final_state.csv of an earlier run of this scene (its t, q, v)");

  sweep::BenchOptions bench_options;
  CLI::App* bench = app.add_subcommand("bench", "run time against penetration over h and schemes");
  addSceneOptions(bench);
  bench->add_option("--dt", bench_options.steps, "time steps (comma-separated)")
      ->delimiter(',')
      ->required();
  bench->add_option("--scheme", bench_options.schemes, "schemes (comma-separated)")
      ->delimiter(',')
      ->default_val(std::vector<std::string>{"moreau-jean", "catching-up"});
  bench->add_option("--repeat", bench_options.repeat, "runs per point (the fastest counts)")
      ->default_val(1);
  bench->add_option("--t-end", t_end, "end time (s)");
  bench->add_option("--out", out_dir, "output folder")->default_val("bench");
  bench->add_flag("--no-plots", bench_options.no_plots, "write bench.csv only");
  bench->add_flag("--quiet", quiet, "no progress log; the table is still printed");
  bench->add_option("--threads", threads, "threads (0: every core; default: scheme.threads, 0)");
  bench->add_option("--row-storage", row_storage, "as run's --row-storage")->check(row_storages);

  CLI::App* check = app.add_subcommand("check", "validate a scene and describe it");
  addSceneOptions(check);

  std::string export_path;
  CLI::App* exporter =
      app.add_subcommand("export", "write the scene with every body listed (no generators)");
  addSceneOptions(exporter);
  exporter->add_option("output", export_path, "explicit scene file to write")->required();

  sweep::ViewerOptions view_options;
  CLI::App* view = app.add_subcommand(
      "view", "write one self-contained HTML page that plays a run's snapshots back");
  view->add_option("results", view_options.results_dir,
                   "results folder of a run with snapshots (output.vtk_interval)")
      ->required();
  view->add_option("--out", view_options.out_file, "page to write (default: RESULTS/view.html)");
  view->add_option("--every", view_options.every,
                   "keep every N-th snapshot (and the last); default: every one, thinned to "
                   "keep the page within 500 MB");

#ifdef SWEEP_RANKS
  const sweep::RankGroup ranks = sweep::RankGroup::world();
#else
  struct {
    int rank() const { return 0; }
    int size() const { return 1; }
  } ranks;
#endif
  // on several ranks every rank meets the same errors at the same point (agreeOnRanks): rank 0
  // alone prints them, and the description, the progress and the summary
  const bool root = ranks.rank() == 0;
  std::ostringstream unused;
  std::ostream& out = root ? std::cout : unused;
  std::ostream& err = root ? std::cerr : unused;
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e, out, err);
    return code == 0 ? 0 : 2;
  }

  try {
#ifdef SWEEP_RANKS
    // a launcher of another MPI than the one this sweep links starts each process alone: every
    // one would run the whole scene and write the same files
    std::string variable;
    if (const int launched = sweep::launchedRanks(&variable); launched > 1 && ranks.size() == 1)
      throw sweep::InputError("started as one of " + std::to_string(launched) + " MPI processes (" +
                              variable +
                              "), but MPI sees this process alone: the launcher is not the one "
                              "of the MPI sweep was built with (Open MPI's mpirun); every "
                              "process would write the same files");
    if (ranks.size() > 1 && !run->parsed())
      throw sweep::InputError("started as one of " + std::to_string(ranks.size()) +
                              " MPI processes: only `sweep run` runs on ranks; start `sweep " +
                              app.get_subcommands().front()->get_name() + "` as one process");
#else
    if (run->parsed() || bench->parsed()) refuseSeveralRanks();
#endif
    // an empty folder name would write nothing (run) or into the filesystem root (bench)
    if ((run->parsed() || bench->parsed()) && out_dir.empty())
      throw sweep::InputError("--out: must name a folder, got ''");
    if (exporter->parsed()) {
      std::error_code error;
      if (export_path.empty()) throw sweep::InputError("export: OUTPUT must name a file, got ''");
      if (std::filesystem::is_directory(export_path, error))
        throw sweep::InputError(export_path + ": is a folder; export writes a scene file");
      sweep::requireOutputFile(export_path);
    }
    if (view->parsed()) {
      if (view->count("--every") > 0 && view_options.every < 1)
        throw sweep::InputError("--every: must be >= 1, got " + std::to_string(view_options.every));
      view_options.log = &std::cerr;
      const std::string page = sweep::writeViewer(view_options);
      std::cout << "wrote " << page << "\n";
      return 0;
    }
    // the scene with the command line's overrides, built and checked: every rank of a run on
    // ranks does this by itself, and agrees on the outcome before the run
    std::optional<sweep::SceneFile> loaded;
    std::optional<sweep::Scene> built;
    sweep::SavedState start;
    std::exception_ptr load_error;
    try {
      loaded.emplace(sweep::loadSceneFile(scene_path, overrides, settings_files));
      sweep::SceneFile& file = *loaded;
      if (!scheme_name.empty()) file.run.scheme.scheme = sweep::schemeFromName(scheme_name);
      // given at all, whatever its value: -1 is refused like any other negative count
      const bool threads_given = (run->parsed() && run->count("--threads") > 0) ||
                                 (bench->parsed() && bench->count("--threads") > 0);
      if (threads_given) {
        if (threads < 0 || threads > 1024)
          throw sweep::InputError("--threads: must be in [0, 1024] (0: every core), got " +
                                  std::to_string(threads));
        file.run.scheme.threads = threads;
      }
      if (ranks.size() > 1 && file.run.scheme.threads == 0)
        file.run.scheme.threads = threadsPerRank(ranks.size());
      if (row_storage == "generic") file.run.scheme.packed_rows = false;
      if (row_storage == "body-form") file.run.scheme.compact_sphere_rows = false;
      if (row_storage == "compact") file.run.scheme.compact_sphere_rows = true;
      if (run->parsed() && run->count("--dt") > 0) {
        if (!(dt > 0.0) || !std::isfinite(dt))
          throw sweep::InputError("--dt: must be > 0, got " + sweep::exactNumber(dt));
        file.run.scheme.h = dt;
      }
      if ((run->parsed() || bench->parsed()) &&
          app.get_subcommand(run->parsed() ? "run" : "bench")->count("--t-end") > 0) {
        if (!(t_end > 0.0) || !std::isfinite(t_end))
          throw sweep::InputError("--t-end: must be > 0, got " + sweep::exactNumber(t_end));
        file.run.t_end = t_end;
      }
      built.emplace(sweep::buildSceneFile(file));
      file.run.scheme.validate();
      // what `run` refuses at load, `check` and the others refuse too, with the same words
      try {
        sweep::stepCount(0.0, file.run.t_end, file.run.scheme.h);
      } catch (const sweep::InputError& e) {
        throw sweep::InputError(scene_path + ": " + e.what());
      }
      if (run->parsed() && !initial_state.empty())
        start = sweep::readSavedState(initial_state, *built, file.spec.max_initial_overlap);
      if (run->parsed()) {
        try {
          sweep::stepCount(start.t, file.run.t_end, file.run.scheme.h);
        } catch (const sweep::InputError& e) {
          throw sweep::InputError(scene_path + ": " + e.what());
        }
      }
    } catch (...) {
      load_error = std::current_exception();
    }
#ifdef SWEEP_RANKS
    sweep::agreeOnRanks(ranks, load_error);
#else
    if (load_error) std::rethrow_exception(load_error);
#endif
    sweep::SceneFile& file = *loaded;
    const sweep::Scene& scene = *built;

    if (check->parsed()) {
      describeScene(file, scene, std::cout);
      std::cout << "scene is valid\n";
      return 0;
    }
    if (exporter->parsed()) {
      sweep::writeSceneFile(file, export_path);
      std::cout << "wrote " << export_path << " (" << file.spec.bodies.size() << " bodies)\n";
      return 0;
    }
    if (run->parsed()) {
      describeScene(file, scene, out);
      if (ranks.size() > 1) {
        out << "  on " << ranks.size() << " MPI ranks";
        // the staggered scheme's stages sweep across the ranks whatever `auto` takes in one
        // process (integrators/distributed_stepper.hpp)
        const sweep::SchemeSettings& scheme_settings = file.run.scheme;
        if (scheme_settings.scheme == sweep::Scheme::CatchingUp) {
          auto swept = [](const sweep::SolverSettings& stage) {
            return stage.solver == sweep::StageSolver::Auto ||
                           stage.acceleration == sweep::NlgsAcceleration::Nncg
                       ? "nlgs with nncg"
                       : "nlgs";
          };
          out << ", stages by " << swept(scheme_settings.normal_stage) << " + "
              << swept(scheme_settings.friction_stage) << " across the ranks";
        }
        out << "\n";
      }
      sweep::RunOptions options;
      options.out_dir = out_dir;
      options.log = &std::cerr;
      options.progress = !quiet;
      options.progress_bar = isatty(STDERR_FILENO) != 0;
      options.stop = &sweep::stopFlag();
      if (!initial_state.empty()) {
        options.start = &start;
        out << "  starting from " << initial_state << " at t = " << start.t << " s\n";
      }
      const sweep::CooperativeStop polled;  // the loop stops between steps
#ifdef SWEEP_RANKS
      const sweep::RunSummary summary =
          ranks.size() > 1 ? sweep::runSceneOnRanks(ranks, scene, file.run, options, distributed)
                           : sweep::runScene(scene, file.run, options);
#else
      const sweep::RunSummary summary = sweep::runScene(scene, file.run, options);
#endif
      printSummary(summary, out_dir, out);
      if (!summary.failure.empty()) {
        err << "sweep: failed: " << summary.failure << " (outputs written up to it)\n";
        return 1;
      }
      return summary.interrupted ? sweep::stopExitCode() : 0;
    }
    bench_options.out_dir = out_dir;
    bench_options.log = quiet ? nullptr : &std::cerr;
    bench_options.stop = &sweep::stopFlag();
    describeScene(file, scene, std::cout);
    const sweep::CooperativeStop polled;
    const int code = sweep::runBench(file, scene, bench_options, std::cout);
    return code == 130 ? sweep::stopExitCode() : code;
  } catch (const sweep::InputError& e) {
    err << "sweep: error: " << e.what() << "\n";
    return 2;
  } catch (const std::exception& e) {
    err << "sweep: failed: " << e.what() << "\n";
    return 1;
  }
}

int main(int argc, char** argv) {
#ifdef SWEEP_RANKS
  // started by a launcher as one of several processes: MPI for the life of the command; one
  // process (or one rank) runs without it, exactly as a build without MPI
  std::optional<sweep::MpiSession> mpi;
  if (sweep::launchedRanks() > 1) mpi.emplace(argc, argv);
#endif
  const int code = runCommand(argc, argv);
  // a report lost on a full disk or a closed pipe is a failed run, not a silent success
  std::cout.flush();
  if (!std::cout.good()) {
    std::cerr << "sweep: failed: cannot write to standard output\n";
    return code == 0 ? 1 : code;
  }
  return code;
}
