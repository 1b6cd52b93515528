#include "integrators/stage_solvers.hpp"

#include "integrators/convex_stages.hpp"
#include "integrators/nlgs.hpp"

namespace sweep {

namespace {

// The solver `auto` stands for. In 3D, where every row joins free bodies (body-form and sphere
// rows: grains, walls, a blade), NLGS with NNCG, swept in colours on threads: a row moves at
// most two bodies, so a sweep is cheap and W's rows are weakly coupled; on the powder heap and
// the settling piles it is faster than MPRGP / APGD at every tolerance from 1e-3 to 1e-6
// (docs/benchmarks.md). Rows on articulated bodies (entry rows: a slider-crank) couple through
// the joint-space mass matrix and keep the convex solvers (Gauss-Seidel hits its cap there).
SolverSettings resolveAuto(const ContactProblem& p, const SolverSettings& settings) {
  if (settings.solver != StageSolver::Auto || p.dimension != 3) return settings;
  const std::size_t free_body_rows =
      p.spheres3d.size() + static_cast<std::size_t>(p.direct_body_forms);
  if (p.size() == 0 || free_body_rows != static_cast<std::size_t>(p.size())) return settings;
  SolverSettings nlgs = settings;
  nlgs.solver = StageSolver::Nlgs;
  nlgs.acceleration = NlgsAcceleration::Nncg;
  return nlgs;
}

}  // namespace

SolverStats solveNormalStage(const ContactProblem& p, const SolverSettings& given,
                             std::vector<double>& lambda_N, VectorX& v, SolverWorkspace& ws) {
  const SolverSettings settings = resolveAuto(p, given);
  if (settings.solver == StageSolver::Nlgs)
    return solveNormalStageNlgs(p, settings, lambda_N, v, ws);
  return solveNormalStageConvex(p, settings, lambda_N, v, ws);
}

SolverStats solveFrictionStage(const ContactProblem& p, const SolverSettings& given,
                               const FrictionStageOptions& options,
                               const std::vector<double>& lambda_N, std::vector<double>& delta,
                               std::vector<Vector2>& lambda_T, VectorX& v, SolverWorkspace& ws,
                               std::vector<Vector2>* R,
                               const std::vector<double>* threshold_impulse) {
  const SolverSettings settings = resolveAuto(p, given);
  if (settings.solver == StageSolver::Nlgs)
    return solveFrictionStageNlgs(p, settings, options, lambda_N, delta, lambda_T, v, ws, R,
                                  threshold_impulse);
  return solveFrictionStageConvex(p, settings, options, lambda_N, delta, lambda_T, v, ws, R,
                                  threshold_impulse);
}

}  // namespace sweep
