#include "integrators/stage_solvers.hpp"

#include "integrators/convex_stages.hpp"
#include "integrators/nlgs.hpp"

namespace sweep {

SolverStats solveNormalStage(const ContactProblem& p, const SolverSettings& settings,
                             std::vector<double>& lambda_N, VectorX& v, SolverWorkspace& ws) {
  if (settings.solver == StageSolver::Nlgs)
    return solveNormalStageNlgs(p, settings, lambda_N, v, ws);
  return solveNormalStageConvex(p, settings, lambda_N, v, ws);
}

SolverStats solveFrictionStage(const ContactProblem& p, const SolverSettings& settings,
                               const FrictionStageOptions& options,
                               const std::vector<double>& lambda_N, std::vector<double>& delta,
                               std::vector<Vector2>& lambda_T, VectorX& v, SolverWorkspace& ws,
                               std::vector<Vector2>* R,
                               const std::vector<double>* threshold_impulse) {
  if (settings.solver == StageSolver::Nlgs)
    return solveFrictionStageNlgs(p, settings, options, lambda_N, delta, lambda_T, v, ws, R,
                                  threshold_impulse);
  return solveFrictionStageConvex(p, settings, options, lambda_N, delta, lambda_T, v, ws, R,
                                  threshold_impulse);
}

}  // namespace sweep
