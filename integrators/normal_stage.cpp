// Scheme B's stage 5a by NLGS (integrators/nlgs.hpp): sweeps of normalUpdate
// (integrators/contact_laws.hpp) over each island's rows, on normals scaled to unit M^-1
// norm, s_c = sqrt(W_NN,c); Lambda = s lambda.
#include <algorithm>
#include <cmath>

#include "integrators/contact_laws.hpp"
#include "integrators/nlgs.hpp"
#include "integrators/rows.hpp"
#include "integrators/sweeps.hpp"

namespace sweep {

namespace {

SolverStats normalIsland(const ContactProblem& p, const SolverSettings& settings,
                         std::vector<double>& lambda_N, VectorX& v, SolverWorkspace& ws, int n) {
  // packed rows where the problem has them: their 1 / W_NN is the assembly's, so the sweeps
  // give the entry rows' bits
  const RowReader rows(p, RowReader::kPacked2d | RowReader::kPacked3d | RowReader::kSpheres3d);
  const bool coloured = colourForThreads(p, settings, rows.packed(), ws, n);
  const int* order = ws.order.data();
  return sweepIsland(
      p, settings, ws, n, coloured, {impulses(lambda_N)}, v,
      [&](int first, int last, double& change2, double& size2, int&) {
        rows.forEach(
            order, first, last, [&](int k, const auto& row) __attribute__((always_inline)) {
              normalUpdate(row, settings.relaxation, lambda_N[order[k]], v, change2, size2);
            });
      },
      [&](int first, int last, double& f2, double& scale2) {
        rows.forEach(
            order, first, last, [&](int k, const auto& row) __attribute__((always_inline)) {
              normalResidualTerms(row, lambda_N[order[k]], v, f2, scale2);
            });
      });
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
