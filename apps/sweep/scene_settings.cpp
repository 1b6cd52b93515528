// The scene file's settings (scene_parser.hpp): detection, the scheme and its solvers, time
// and outputs.
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "apps/sweep/scene_parser.hpp"
#include "framework/error.hpp"
#include "framework/memory.hpp"
#include "models/funnel.hpp"
#include "models/powder_bed.hpp"

namespace sweep {

void SceneParser::parseDetection(const YamlField& f) {
  f.allowOnly({"path", "speed_factor", "margin_rule", "verify_margin", "margin", "self_collision",
               "max_initial_overlap", "periodic"});
  DetectionSettings& d = out_.spec.detection;
  d.path = f.choice("path", DetectionPathChoice::Automatic);
  d.speed_factor = f.nonNegative("speed_factor", d.speed_factor);
  d.verify_margin = f.boolean("verify_margin", d.verify_margin);
  d.margin_rule = f.choice("margin_rule", d.margin_rule);
  d.floor = f.nonNegative("margin", d.floor);
  d.self_collision = f.boolean("self_collision", d.self_collision);
  out_.spec.max_initial_overlap = f.number("max_initial_overlap", out_.spec.max_initial_overlap);
  if (f.has("periodic")) {
    const YamlField periodic = f["periodic"];
    periodic.allowOnly({"axis", "low", "high"});
    const std::string axis = periodic["axis"].text();
    if (axis != "x" && axis != "y" && (axis != "z" || out_.spec.dimension == 2))
      periodic["axis"].fail(out_.spec.dimension == 2 ? "must be x or y" : "must be x, y or z");
    d.periodic.axis = axis[0] - 'x';
    d.periodic.low = periodic["low"].number();
    d.periodic.high = periodic["high"].number();
    if (!(d.periodic.high > d.periodic.low)) periodic["high"].fail("must be > low");
  }
}

// convex: a stage of scheme B, which may take the convex solver
// stage: one of scheme B's stages, which choose their solver; scheme A's coupled problem
// is not convex and takes NLGS only, with its 3D local solver and its coloured sweeps
SolverSettings SceneParser::parseSolver(const YamlField& f, SolverSettings s, bool stage) {
  if (stage)
    f.allowOnly({"solver", "max_iterations", "tolerance", "residual_check_interval", "relaxation",
                 "shuffle", "seed", "acceleration"});
  else
    f.allowOnly({"max_iterations", "tolerance", "residual_check_interval", "relaxation", "shuffle",
                 "seed", "local_solver", "acceleration", "parallel_rows"});
  if (stage) s.solver = f.choice("solver", s.solver);
  const long cap = f.integer("max_iterations", s.max_iterations);
  if (cap < 1 || cap > 100000000) f["max_iterations"].fail("must be in [1, 10^8]");
  s.max_iterations = static_cast<int>(cap);
  s.tolerance = f.positive("tolerance", s.tolerance);
  const long interval = f.integer("residual_check_interval", s.residual_check_interval);
  if (interval < 0 || interval > 100000000)
    f["residual_check_interval"].fail("must be in [0, 10^8] (0: only once the impulses settle)");
  s.residual_check_interval = static_cast<int>(interval);
  s.relaxation = f.positive("relaxation", s.relaxation);
  if (!(s.relaxation < 2.0)) f["relaxation"].fail("must be in (0, 2)");
  s.shuffle = f.boolean("shuffle", s.shuffle);
  const long seed = f.integer("seed", s.seed);
  if (seed < 0 || seed > 4294967295L) f["seed"].fail("must be in [0, 2^32)");
  s.seed = static_cast<std::uint32_t>(seed);
  s.acceleration = f.choice("acceleration", s.acceleration);
  if (stage) return s;
  s.local_solver_3d = f.choice("local_solver", LocalSolver3d::AlartCurnier);
  const long parallel_rows = f.integer("parallel_rows", s.parallel_rows);
  if (parallel_rows < 1 || parallel_rows > 1000000000L)
    f["parallel_rows"].fail("must be in [1, 10^9]");
  s.parallel_rows = static_cast<int>(parallel_rows);
  return s;
}

void SceneParser::parseScheme(const YamlField& f) {
  f.allowOnly({"name", "normal_law", "tangents", "threshold", "threshold_updates", "open_contacts",
               "coulomb", "normal_stage", "friction_stage", "screening", "screening_rounds",
               "screening_gap", "projection", "threads"});
  SchemeSettings& s = out_.run.scheme;
  if (f.has("name")) s.scheme = f.choice("name", s.scheme);
  s.normal_law = f.choice("normal_law", NormalLaw::Vel);
  s.friction.tangents = f.choice("tangents", TangentMode::Global);
  const long updates = f.integer("threshold_updates", s.friction.threshold_updates);
  if (updates < 0 || updates > 100) f["threshold_updates"].fail("must be in [0, 100]");
  s.friction.threshold_updates = static_cast<int>(updates);
  s.friction.threshold = f.choice("threshold", FrictionThreshold::Physical);
  s.friction.open_contacts = f.choice("open_contacts", OpenContacts::Unilateral);
  s.screening = f.boolean("screening", s.screening);
  const long rounds = f.integer("screening_rounds", s.screening_rounds);
  if (rounds < 1 || rounds > 1000) f["screening_rounds"].fail("must be in [1, 1000]");
  s.screening_rounds = static_cast<int>(rounds);
  if (f.has("screening_gap")) s.screening_gap = f.nonNegative("screening_gap", 0.0);
  if (f.has("projection")) {
    const YamlField p = f["projection"];
    p.allowOnly({"max_rounds", "tolerance"});
    const long max_rounds = p.integer("max_rounds", s.projection.max_rounds);
    if (max_rounds < 0 || max_rounds > 100) p["max_rounds"].fail("must be in [0, 100] (0: off)");
    s.projection.max_rounds = static_cast<int>(max_rounds);
    s.projection.tolerance = p.positive("tolerance", s.projection.tolerance);
  }
  const long threads = f.integer("threads", s.threads);
  if (threads < 0 || threads > 1024) f["threads"].fail("must be in [0, 1024] (0: every core)");
  s.threads = static_cast<int>(threads);
  if (f.has("coulomb")) s.coulomb = parseSolver(f["coulomb"], s.coulomb, false);
  if (f.has("normal_stage")) s.normal_stage = parseSolver(f["normal_stage"], s.normal_stage, true);
  if (f.has("friction_stage"))
    s.friction_stage = parseSolver(f["friction_stage"], s.friction_stage, true);
}

void SceneParser::parseTime(const YamlField& f) {
  f.allowOnly({"step", "end"});
  out_.run.scheme.h = f.positive("step", out_.run.scheme.h);
  out_.run.t_end = f.positive("end", out_.run.t_end);
}

void SceneParser::parseOutput(const YamlField& f) {
  f.allowOnly({"stats", "timings", "vtk_every", "vtk_interval", "layer"});
  OutputSettings& o = out_.run.output;
  if (f.has("layer")) {
    const YamlField l = f["layer"];
    // the metrics are of spheres over a plate, across a width along z: a 2D scene has none
    if (out_.spec.dimension == 2)
      l.fail("measures a 3D powder layer (spheres over a plate); a 2D scene has none");
    l.allowOnly({"x_min", "x_max", "z_min", "z_max", "plate", "gap", "cell", "resolution"});
    LayerWindow w = powder_layer_ ? *powder_layer_ : LayerWindow{};
    w.x_min = l.number("x_min", w.x_min);
    w.x_max = l.number("x_max", w.x_max);
    w.z_min = l.number("z_min", w.z_min);
    w.z_max = l.number("z_max", w.z_max);
    w.plate = l.number("plate", w.plate);
    w.gap = l.number("gap", w.gap);
    w.cell = l.number("cell", w.cell);
    w.resolution = l.number("resolution", w.resolution);
    try {
      w.validate(l.path());
    } catch (const InputError& e) {
      throw InputError(path_ + ": " + e.what());
    }
    o.layer = w;
  }
  o.stats = f.boolean("stats", o.stats);
  o.timings = f.boolean("timings", o.timings);
  o.vtk_every = f.integer("vtk_every", o.vtk_every);
  if (o.vtk_every < 0) f["vtk_every"].fail("must be >= 0");
  o.vtk_interval = f.nonNegative("vtk_interval", o.vtk_interval);
}

}  // namespace sweep
