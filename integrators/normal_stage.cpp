// Scheme B's stage 5a by NLGS (integrators/nlgs.hpp): sweeps of normalUpdate
// (integrators/contact_laws.hpp) over each island's rows, on normals scaled to unit M^-1
// norm, s_c = sqrt(W_NN,c); Lambda = s lambda.
#include <algorithm>
#include <cmath>
#include <optional>

#include "integrators/contact_laws.hpp"
#include "integrators/nlgs.hpp"
#include "integrators/rows.hpp"
#include "integrators/sweeps.hpp"

namespace sweep {

namespace {

double normalResidual(const RowReader& rows, const std::vector<double>& lambda_N, const VectorX& v,
                      const SolverWorkspace& ws, int count) {
  double f2 = 0.0, scale2 = 0.0;
  rows.forEach(
      ws.order.data(), 0, count, [&](int k, const auto& row) __attribute__((always_inline)) {
        normalResidualTerms(row, lambda_N[ws.order[k]], v, f2, scale2);
      });
  return relative(f2, scale2);
}

SolverStats normalIsland(const ContactProblem& p, const SolverSettings& settings,
                         std::vector<double>& lambda_N, VectorX& v, SolverWorkspace& ws, int n) {
  SolverStats stats;
  // 3D rows from the generic arrays: the packed 3D rows carry no 1 / W_NN of their own
  const RowReader rows(p, RowReader::kPacked2d);
  std::optional<NncgMomentum> momentum;
  if (settings.acceleration == NlgsAcceleration::Nncg)
    momentum.emplace(p, std::initializer_list<ImpulseArray>{impulses(lambda_N)}, v, ws, n);
  for (int it = 0; it < settings.max_iterations; ++it) {
    nextOrder(settings, ws, it, n);
    double change2 = 0.0, size2 = 0.0;
    rows.forEach(
        ws.order.data(), 0, n, [&](int k, const auto& row) __attribute__((always_inline)) {
          normalUpdate(row, settings.relaxation, lambda_N[ws.order[k]], v, change2, size2);
        });
    stats.iterations = it + 1;
    if (residualDue(settings, it, change2, size2)) {
      stats.residual = normalResidual(rows, lambda_N, v, ws, n);
      if (momentum) momentum->watch(stats.residual);
      if (stats.residual < settings.tolerance) return stats;
    }
    if (momentum && it + 1 < settings.max_iterations) momentum->step(change2, v);
  }
  stats.residual = normalResidual(rows, lambda_N, v, ws, n);
  stats.status =
      stats.residual < settings.tolerance ? SolverStatus::Converged : SolverStatus::MaxIterations;
  return stats;
}

}  // namespace

SolverStats solveNormalStageNlgs(const ContactProblem& p, const SolverSettings& settings,
                                 std::vector<double>& lambda_N, VectorX& v, SolverWorkspace& ws) {
  SolverStats total;
  for (int c = 0; c < p.size(); ++c) p.applyImpulse(c, Vector3(lambda_N[c], 0, 0), v);
  if (p.size() == 0) return total;
  prepareNncg(settings, p, v, ws);
  for (int island = 0; island < p.islandCount(); ++island) {
    const int n = selectIsland(p, island, ws);
    SolverStats island_stats = normalIsland(p, settings, lambda_N, v, ws, n);
    island_stats.updates = static_cast<long>(island_stats.iterations) * n;
    mergeIsland(total, island_stats);
  }
  if (!v.allFinite()) total.status = SolverStatus::Failed;
  return total;
}

}  // namespace sweep
