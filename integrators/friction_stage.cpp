// Scheme B's stage 5b: the setup both of its solvers share (integrators/friction_stage.hpp)
// and its NLGS solver (integrators/nlgs.hpp).
#include "integrators/friction_stage.hpp"

#include <algorithm>
#include <cmath>

#include "integrators/contact_laws.hpp"
#include "integrators/convex_stages.hpp"
#include "integrators/nlgs.hpp"
#include "integrators/rows.hpp"
#include "integrators/sweeps.hpp"

namespace sweep {

FrictionBlock frictionBlock(const ContactProblem& p, int c) {
  const Matrix3& W = p.delassus[c];
  FrictionBlock b;
  b.coupling = W.block<2, 1>(1, 0) / W(0, 0);
  b.schur = W.block<2, 2>(1, 1) - W.block<2, 1>(1, 0) * W.block<1, 2>(0, 1) / W(0, 0);
  if (p.dimension == 2) {
    b.coupling.y() = 0.0;
    b.schur(0, 1) = b.schur(1, 0) = 0.0;
    b.schur(1, 1) = 1.0;  // unused direction, kept invertible
  }
  return b;
}

void prepareFrictionStage(const ContactProblem& p, const FrictionStageOptions& options,
                          const std::vector<double>& lambda_N,
                          const std::vector<double>* threshold_impulse, const VectorX& v1,
                          SolverWorkspace& ws) {
  for (int c = 0; c < p.size(); ++c) {
    const FrictionBlock block = frictionBlock(p, c);
    ws.coupling[c] = block.coupling;
    ws.schur[c] = block.schur;
    const Matrix3& W = p.delassus[c];
    double S = p.friction[c] * (threshold_impulse ? (*threshold_impulse)[c] : lambda_N[c]);
    if (options.threshold == FrictionThreshold::Metric && p.dimension == 2)
      S *= std::sqrt(W(0, 0) / block.schur(0, 0));
    ws.threshold[c] = S;
    ws.held_normal[c] = p.localVelocity(c, v1).x();
  }
}

void warmStartFriction(const FrictionStageRows& stage, bool any, VectorX& v) {
  const ContactProblem& p = stage.p;
  for (int c = 0; c < p.size(); ++c) {
    if (stage.rule.guarded(c))
      stage.delta[c] = any ? std::max(stage.delta[c], 0.0) : 0.0;
    else if (!stage.rule.held(c))
      stage.delta[c] = 0.0;
    if (stage.ws.threshold[c] <= 0.0) stage.lambda_T[c].setZero();
    Vector3 warm = stage.tangentMap(c, stage.lambda_T[c]);
    warm.x() += stage.delta[c];
    p.applyImpulse(c, warm, v);
  }
  warmStartRolling(p, stage.R, v);
}

namespace {

// The sweeps of one island, ws.order[0, count), to the tolerance or the cap. The periodic
// residual check as in the other stages: with GLOBAL tangents in a hyperstatic heap the
// bilateral corrections drift along redundant rows while the friction law is met.
SolverStats frictionIsland(const FrictionStageRows& stage, const RowReader& rows,
                           const SolverSettings& settings, VectorX& v, SolverWorkspace& ws,
                           int count) {
  const bool coloured = colourForThreads(stage.p, settings, rows.packed(), ws, count);
  const int* order = ws.order.data();
  SolverStats stats = sweepIsland(
      stage.p, settings, ws, count, coloured,
      {impulses(&stage.lambda_T), impulses(stage.delta), impulses(stage.R)}, v,
      [&](int first, int last, double& change2, double& size2, int&) {
        rows.forEach(
            order, first, last, [&](int k, const auto& row) __attribute__((always_inline)) {
              stage.update(row, order[k], v, change2, size2);
            });
      },
      [&](int first, int last, double& f2, double& scale2) {
        rows.forEach(
            order, first, last, [&](int k, const auto& row) __attribute__((always_inline)) {
              stage.residualTerms(row, order[k], v, f2, scale2);
            });
      });
  stats.updates = static_cast<long>(stats.iterations) * count;
  return stats;
}

}  // namespace

SolverStats solveFrictionStageNlgs(const ContactProblem& p, const SolverSettings& settings,
                                   const FrictionStageOptions& options,
                                   const std::vector<double>& lambda_N, std::vector<double>& delta,
                                   std::vector<Vector2>& lambda_T, VectorX& v, SolverWorkspace& ws,
                                   std::vector<Vector2>* R,
                                   const std::vector<double>* threshold_impulse) {
  // thresholds frozen from stage 5a; the normal velocities of closed contacts (GLOBAL)
  // are held at their stage-5a values
  prepareFrictionStage(p, options, lambda_N, threshold_impulse, v, ws);
  const FrictionRowRule rule{p, options, lambda_N};
  bool any = false;
  for (int c = 0; c < p.size(); ++c)
    any = any || ws.threshold[c] > 0.0 || (hasRollingRow(p, R, c) && lambda_N[c] > 0.0);
  SolverStats total;
  std::fill(ws.offset.begin(), ws.offset.end(), Vector2::Zero());
  // the projection's products count as row visits, as in the convex solvers' stats
  if (any && rule.needsProjection())
    total.updates += projectOnClosedNormalsByCg(p, settings, rule, v, ws);
  const FrictionStageRows stage{
      p, options, rule, ws, lambda_N, delta, lambda_T, R, settings.relaxation};
  warmStartFriction(stage, any, v);
  if (!any) return total;
  // packed 3D rows (entry, body form or compact sphere rows) hold the rolling rows too: read
  // so when R covers every row
  const bool rolling_fits = R == nullptr || static_cast<int>(R->size()) == p.size();
  const RowReader rows(
      p, RowReader::kPacked2d | (rolling_fits ? RowReader::kPacked3d | RowReader::kSpheres3d : 0u));
  prepareNncg(settings, p, v, ws);
  for (int island = 0; island < p.islandCount(); ++island) {
    const int count = selectIsland(p, island, ws);
    mergeIsland(total, frictionIsland(stage, rows, settings, v, ws, count));
  }
  if (!v.allFinite()) total.status = SolverStatus::Failed;
  return total;
}

double tangentNormalPart(const ContactProblem& p, int c, const FrictionStageOptions& options,
                         const Vector2& lambda_T) {
  if (options.tangents != TangentMode::Local) return 0.0;
  return -frictionBlock(p, c).coupling.dot(lambda_T);
}

}  // namespace sweep
