// Scheme A's coupled Newton-Coulomb problem by NLGS (integrators/nlgs.hpp): sweeps of
// coulombUpdate (integrators/contact_laws.hpp) over each island's rows.
#include <algorithm>
#include <cmath>

#include "integrators/contact_laws.hpp"
#include "integrators/nlgs.hpp"
#include "integrators/rows.hpp"
#include "integrators/sweeps.hpp"

namespace sweep {

namespace {

// The residual's sums over the rows order[0, count)
void coulombResidualTerms(const RowReader& rows, const std::vector<Vector3>& P,
                          const std::vector<Vector2>* R, const VectorX& v, const int* order,
                          int count, double& f2, double& scale2) {
  const bool prefetch = rows.packed3d();
  rows.forEach(
      order, 0, count, [&](int k, const auto& row) __attribute__((always_inline)) {
        const int c = order[k];
        if (prefetch) prefetchSphereRow(rows.packedRows3d(), order, k, count, v);
        coulombResidualTerms(row, P[c], R != nullptr ? &(*R)[c] : nullptr, v, f2, scale2);
      });
}

// The rows order[first, last) updated once each, in order.
struct CoulombSweep {
  const RowReader& rows;
  const SolverSettings& settings;
  std::vector<Vector3>& P;
  std::vector<Vector2>* R;
  const int* order;

  [[gnu::always_inline]] void operator()(int first, int last, VectorX& v, double& change2,
                                         double& size2, int& failures) const {
    const bool prefetch = rows.packed3d();
    rows.forEach(
        order, first, last, [&](int k, const auto& row) __attribute__((always_inline)) {
          const int c = order[k];
          if (prefetch) prefetchSphereRow(rows.packedRows3d(), order, k, last, v);
          coulombUpdate(row, settings.relaxation, settings.local_solver_3d, P[c],
                        R != nullptr ? &(*R)[c] : nullptr, v, change2, size2, failures);
        });
  }
};

SolverStats coulombIsland(const ContactProblem& p, const SolverSettings& settings,
                          std::vector<Vector3>& P, std::vector<Vector2>* R, VectorX& v,
                          SolverWorkspace& ws, int n, bool velocity_holds_warm_start) {
  // packed 3D rows hold the rolling rows too: read so when R covers every row
  const bool rolling_fits = R == nullptr || static_cast<int>(R->size()) == p.size();
  const RowReader rows(
      p, RowReader::kPacked2d | (rolling_fits ? RowReader::kPacked3d | RowReader::kSpheres3d : 0u));
  const bool coloured = colourForThreads(p, settings, rows.packed(), ws, n);
  // the warm start of the island's rows (the other islands move other velocities): a
  // coloured island's chunk by chunk, as its sweeps go; none where v holds it already
  if (velocity_holds_warm_start) {
    // v = v_free + M^-1 H P
  } else if (coloured) {
    forEachColourChunk(ws, settings.threads, [&](int chunk) {
      const int first = ws.chunk_begin[chunk], last = ws.chunk_begin[chunk + 1];
      warmStart(p, P, R, ws.order.data() + first, last - first, v);
    });
  } else {
    warmStart(p, P, R, ws.order.data(), n, v);
  }
  const CoulombSweep sweep{rows, settings, P, R, ws.order.data()};
  // every packed form: the residual reads what the generic arrays hold, to the bit
  const RowReader residual_rows(
      p, RowReader::kPacked2d | RowReader::kPacked3d | RowReader::kSpheres3d);
  return sweepIsland(
      p, settings, ws, n, coloured, {impulses(P), impulses(R)}, v,
      [&](int first, int last, double& change2, double& size2, int& failures) {
        sweep(first, last, v, change2, size2, failures);
      },
      [&](int first, int last, double& f2, double& scale2) {
        coulombResidualTerms(residual_rows, P, R, v, ws.order.data() + first, last - first, f2,
                             scale2);
      });
}

}  // namespace

void sweepCoulombRows(const ContactProblem& p, const SolverSettings& settings,
                      std::vector<Vector3>& P, std::vector<Vector2>* R, VectorX& v, const int* rows,
                      int count, double& change2, double& size2, int& failures) {
  const bool rolling_fits = R == nullptr || static_cast<int>(R->size()) == p.size();
  const RowReader reader(
      p, RowReader::kPacked2d | (rolling_fits ? RowReader::kPacked3d | RowReader::kSpheres3d : 0u));
  const CoulombSweep sweep{reader, settings, P, R, rows};
  sweep(0, count, v, change2, size2, failures);
}

void coulombResidualSums(const ContactProblem& p, const std::vector<Vector3>& P,
                         const std::vector<Vector2>* R, const VectorX& v, const int* rows,
                         int count, double& f2, double& scale2) {
  const RowReader reader(p, RowReader::kPacked2d | RowReader::kPacked3d | RowReader::kSpheres3d);
  coulombResidualTerms(reader, P, R, v, rows, count, f2, scale2);
}

SolverStats solveCoulombNlgs(const ContactProblem& p, const SolverSettings& settings,
                             std::vector<Vector3>& P, VectorX& v, SolverWorkspace& ws,
                             std::vector<Vector2>* R, bool velocity_holds_warm_start) {
  SolverStats total;
  if (p.size() == 0) return total;
  prepareNncg(settings, p, v, ws);
  for (int island = 0; island < p.islandCount(); ++island) {
    const int n = selectIsland(p, island, ws);
    SolverStats island_stats =
        coulombIsland(p, settings, P, R, v, ws, n, velocity_holds_warm_start);
    island_stats.updates = static_cast<long>(island_stats.iterations) * n;
    mergeIsland(total, island_stats);
  }
  if (!v.allFinite()) total.status = SolverStatus::Failed;
  return total;
}

}  // namespace sweep
