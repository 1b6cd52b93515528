#include "integrators/nlgs.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>

#include "framework/error.hpp"
#include "integrators/convex_stages.hpp"
#include "integrators/coulomb_local.hpp"
#include "integrators/packed_rows.hpp"

namespace sweep {
namespace {
// Coloured sweeps: blocks of kColourChunk consecutive rows in 64 colours of blocks that share
// no component (a bit each in a 64-bit mask), then one colour swept by one thread for the
// rest. A block is about 3 us of work on the 2D funnel: long beside a barrier, short enough
// to give each thread several per colour.
constexpr int kColours = 64;
constexpr int kColourChunk = 128;
}  // namespace

const char* solverStatusName(SolverStatus status) {
  switch (status) {
    case SolverStatus::Converged:
      return "converged";
    case SolverStatus::MaxIterations:
      return "max-iterations";
    case SolverStatus::Failed:
      return "failed";
  }
  return "?";
}
const char* tangentModeName(TangentMode mode) {
  switch (mode) {
    case TangentMode::Global:
      return "global";
    case TangentMode::Local:
      return "local";
    case TangentMode::None:
      return "none";
  }
  return "?";
}
const char* nlgsAccelerationName(NlgsAcceleration acceleration) {
  return acceleration == NlgsAcceleration::Nncg ? "nncg" : "none";
}
const char* frictionThresholdName(FrictionThreshold threshold) {
  return threshold == FrictionThreshold::Physical ? "physical" : "metric";
}
const char* openContactsName(OpenContacts open) {
  return open == OpenContacts::Unilateral ? "unilateral" : "free";
}

const char* stageSolverName(StageSolver solver) {
  switch (solver) {
    case StageSolver::Mprgp:
      return "mprgp";
    case StageSolver::Newton:
      return "newton";
    case StageSolver::Auto:
      return "auto";
    case StageSolver::Nlgs:
      break;
  }
  return "nlgs";
}

void NlgsSettings::validate(const std::string& owner) const {
  const auto show = formatValue;
  if (threads < 1 || threads > 1024)
    throw InputError(owner + ".threads must be in [1, 1024], got " + std::to_string(threads));
  if (parallel_rows < 1)
    throw InputError(owner + ".parallel_rows must be >= 1, got " + std::to_string(parallel_rows));
  if (residual_check_interval < 0)
    throw InputError(owner + ".residual_check_interval must be >= 0, got " +
                     std::to_string(residual_check_interval));
  if (max_iterations < 1)
    throw InputError(owner + ".max_iterations must be >= 1, got " + std::to_string(max_iterations));
  if (!(std::isfinite(tolerance) && tolerance > 0.0))
    throw InputError(owner + ".tolerance must be > 0, got " + show(tolerance));
  if (!(std::isfinite(relaxation) && relaxation > 0.0 && relaxation < 2.0))
    throw InputError(owner + ".relaxation must be in (0, 2), got " + show(relaxation));
}

void NlgsWorkspace::prepare(int contacts, int nv, int components) {
  y.resize(contacts);
  offset.resize(contacts);
  coupling.resize(contacts);
  schur.resize(contacts);
  if (v_normal.size() < nv) v_normal.resize(nv);
  order.resize(contacts);
  threshold.resize(contacts);
  held_normal.resize(contacts);
  for (int c = 0; c < contacts; ++c) order[c] = c;
  impulse_before.resize(5 * static_cast<std::size_t>(contacts));  // widest: P and R, 3 + 2
  impulse_direction.resize(5 * static_cast<std::size_t>(contacts));
  // coloured sweeps: at most 65 colours (64 and one swept by one thread), chunks of
  // kColourChunk rows; components are fewer than velocities
  row_colour.resize(contacts);
  coloured_order.resize(contacts);
  colour_chunk.resize(kColours + 2);
  const std::size_t chunks = contacts / kColourChunk + kColours + 1;
  chunk_begin.resize(chunks + 1);
  chunk_change2.resize(chunks);
  chunk_size2.resize(chunks);
  chunk_failures.resize(chunks);
  const std::size_t colour_slots = std::max(nv, components);
  if (component_colours.size() < colour_slots) component_colours.assign(colour_slots, 0);
  if (v_before.size() < nv) {
    v_before.resize(nv);
    v_direction.resize(nv);
    island_dofs.resize(nv);
    dof_stamp.assign(nv, 0);
    stamp = 0;
  }
}

namespace {

void nextOrder(const NlgsSettings& settings, NlgsWorkspace& ws, int iteration, int count) {
  if (!settings.shuffle) return;
  if (iteration == 0) ws.rng.seed(settings.seed);
  std::shuffle(ws.order.begin(), ws.order.begin() + count, ws.rng);
}

// Cuts the island's rows ws.order[0, n) into blocks of kColourChunk consecutive rows and
// colours the blocks: a block takes the lowest colour free at every component its rows move,
// so that blocks of one colour share no velocity. The rows are then reordered block by block,
// colour after colour; a block keeps its rows' order (and their locality: rows come in
// detection order, and most blocks are a patch of the scene). Blocks beyond 64 colours, or
// with a row that moves more than two components, go to the last colour, swept by one thread.
void colourIsland(const ContactProblem& p, NlgsWorkspace& ws, int n) {
  const int blocks = (n + kColourChunk - 1) / kColourChunk;
  for (int block = 0; block < blocks; ++block) {
    const int first = block * kColourChunk, last = std::min(n, first + kColourChunk);
    std::uint64_t used = 0;
    bool wide = false;
    const int slots = static_cast<int>(ws.component_colours.size());
    for (int k = first; k < last; ++k) {
      const std::array<int, 2>& moved = p.row_components[ws.order[k]];
      // a workspace prepared without the model's component count may not reach every one:
      // such a block goes to the serial colour
      if (moved[0] < 0 || moved[0] >= slots || moved[1] >= slots) {
        wide = true;
        continue;
      }
      for (int comp : moved)
        if (comp >= 0) used |= ws.component_colours[comp];
    }
    int colour = kColours;
    if (!wide && ~used != 0) {
      colour = __builtin_ctzll(~used);
      for (int k = first; k < last; ++k)
        for (int comp : p.row_components[ws.order[k]])
          if (comp >= 0) ws.component_colours[comp] |= std::uint64_t{1} << colour;
    }
    ws.row_colour[block] = colour;  // per block here
  }
  for (int k = 0; k < n; ++k)  // the masks back to zero for the next island
    for (int comp : p.row_components[ws.order[k]])
      if (comp >= 0 && comp < static_cast<int>(ws.component_colours.size()))
        ws.component_colours[comp] = 0;
  // the blocks colour after colour (in their order within one): chunk j is the j-th
  int chunk = 0, row = 0;
  for (int colour = 0; colour <= kColours; ++colour) {
    ws.colour_chunk[colour] = chunk;
    for (int block = 0; block < blocks; ++block) {
      if (ws.row_colour[block] != colour) continue;
      ws.chunk_begin[chunk++] = row;
      const int first = block * kColourChunk, last = std::min(n, first + kColourChunk);
      for (int k = first; k < last; ++k) ws.coloured_order[row++] = ws.order[k];
    }
  }
  ws.colour_chunk[kColours + 1] = chunk;
  ws.chunk_begin[chunk] = row;
  std::copy(ws.coloured_order.begin(), ws.coloured_order.begin() + n, ws.order.begin());
}

// Runs sweep(chunk) on every chunk, colour after colour; the chunks of one colour on
// `threads` threads. One parallel region per call, a barrier per colour.
template <class Sweep>
void forEachColourChunk(const NlgsWorkspace& ws, int threads, Sweep&& sweep) {
  const int colours = kColours + 1;
  if (threads <= 1) {
    for (int chunk = 0; chunk < ws.colour_chunk[colours]; ++chunk) sweep(chunk);
    return;
  }
#pragma omp parallel num_threads(threads)
  for (int colour = 0; colour < colours; ++colour) {
    const int first = ws.colour_chunk[colour], last = ws.colour_chunk[colour + 1];
    if (first == last) continue;  // the same test on every thread: no barrier skipped by one
    if (colour == kColours) {     // blocks that may share velocities: one thread, in order
#pragma omp single
      for (int chunk = first; chunk < last; ++chunk) sweep(chunk);
    } else {
#pragma omp for schedule(static)
      for (int chunk = first; chunk < last; ++chunk) sweep(chunk);
    }
  }
}

// Callers that prepared the workspace for no velocities get it sized here, once per solve.
void prepareNncg(const NlgsSettings& settings, const ContactProblem& p, const VectorX& v,
                 NlgsWorkspace& ws) {
  if (settings.acceleration == NlgsAcceleration::Nncg &&
      (ws.v_before.size() < v.size() ||
       ws.impulse_before.size() < 5 * static_cast<std::size_t>(p.size())))
    ws.prepare(p.size(), static_cast<int>(v.size()));
}

// Puts the rows of island i in ws.order[0, count) and returns count.
int selectIsland(const ContactProblem& p, int island, NlgsWorkspace& ws) {
  if (p.island_begin.empty()) {
    for (int c = 0; c < p.size(); ++c) ws.order[c] = c;
    return p.size();
  }
  const int begin = p.island_begin[island], end = p.island_begin[island + 1];
  std::copy(p.island_rows.begin() + begin, p.island_rows.begin() + end, ws.order.begin());
  return end - begin;
}

// argmin over |y| <= radius of 1/2 (y - y0)^T A (y - y0) + b^T (y - y0), A SPD 2x2: the
// unconstrained minimizer, or the boundary point where (A + nu I) y = A y0 - b, nu >= 0,
// found by bisection on nu (|y(nu)| decreases with nu).
Vector2 minimizeOnDisc(const Matrix2& A, const Vector2& y0, const Vector2& b, double radius) {
  if (radius <= 0.0) return Vector2::Zero();
  const double trace = A(0, 0) + A(1, 1);
  if (std::abs(A(0, 1)) <= 1e-12 * trace && std::abs(A(0, 0) - A(1, 1)) <= 1e-12 * trace) {
    // isotropic (spheres): the metric projection is the Euclidean one
    const Vector2 y = y0 - b / A(0, 0);
    const double norm = y.norm();
    return norm <= radius ? y : Vector2(y * (radius / norm));
  }
  const Vector2 rhs = A * y0 - b;
  Vector2 y = A.ldlt().solve(rhs);
  if (y.norm() <= radius) return y;
  double lo = 0.0, hi = rhs.norm() / radius;  // at nu = hi, |y| <= |rhs| / nu = radius
  for (int it = 0; it < 100; ++it) {
    const double nu = 0.5 * (lo + hi);
    y = (A + nu * Matrix2::Identity()).ldlt().solve(rhs);
    (y.norm() > radius ? lo : hi) = nu;
  }
  y = (A + hi * Matrix2::Identity()).ldlt().solve(rhs);
  return y * std::min(1.0, radius / y.norm());
}

// Rolling resistance of row c: the torque impulse R on the rolling rows, |R| <= bound with
// bound = mu_r R* (normal impulse), opposing the relative rolling velocity by maximal
// dissipation. One exact local solve on the disc, as for friction; the changes enter the
// convergence measure in units of the bound's lever, mu_r R*, so that torques weigh like
// forces.
// A rolling row's bound per unit normal impulse and W_r, as the residual reads them
struct RollingRow {
  double bound;
  const Matrix2& W;
};
Vector2 rollingTarget(const RollingRow& row, int dimension, double normal_impulse, const Vector2& R,
                      const Vector2& u) {
  const double radius = row.bound * std::max(normal_impulse, 0.0);
  const Matrix2& W = row.W;
  if (dimension == 2) return Vector2(std::clamp(R.x() - u.x() / W(0, 0), -radius, radius), 0.0);
  return minimizeOnDisc(W, R, u, radius);
}
Vector2 rollingTarget(const ContactProblem& p, int c, double normal_impulse, const Vector2& R,
                      const Vector2& u) {
  return rollingTarget({p.rolling_bound[c], p.rolling_delassus[c]}, p.dimension, normal_impulse, R,
                       u);
}

// Relaxation moves an impulse the fraction omega of the way to its local solution, except when
// that solution is zero: a row that opens, opens at once. Relaxed towards zero, its impulse
// would only decay and never become the exact zero that the open-row shortcut of the packed
// updates tests for, and cost time (docs/powder_bed.md, "Under-relaxation, and rows that open
// at once").
template <class Impulse>
[[gnu::always_inline]] inline Impulse relaxedImpulse(const Impulse& solution,
                                                     const Impulse& current, double omega) {
  if (omega == 1.0 || solution.isZero(0.0)) return solution;
  return omega * solution + (1.0 - omega) * current;
}
template <class Impulse>
[[gnu::always_inline]] inline Impulse relaxedChange(const Impulse& solution, const Impulse& current,
                                                    double omega) {
  return solution.isZero(0.0) ? Impulse(-current) : Impulse(omega * (solution - current));
}

// One relaxed update of a rolling row at rolling velocity u; returns the change dR.
Vector2 rollingStep(const ContactProblem& p, int c, double normal_impulse, double omega,
                    const Vector2& u, Vector2& R, double& change2, double& size2) {
  const Vector2 dR = relaxedChange(rollingTarget(p, c, normal_impulse, R, u), R, omega);
  R += dR;
  const double lever2 = p.rolling_bound[c] * p.rolling_bound[c];
  change2 += dR.squaredNorm() / lever2;
  size2 += R.squaredNorm() / lever2;
  return dR;
}

void rollingUpdate(const ContactProblem& p, int c, double normal_impulse, double omega, Vector2& R,
                   VectorX& v, double& change2, double& size2) {
  const Vector2 u = p.rollingVelocity(c, v);
  p.applyRolling(c, rollingStep(p, c, normal_impulse, omega, u, R, change2, size2), v);
}

// natural-map residual of the rolling rows, in the same units
void rollingResidual(const RollingRow& row, int dimension, double normal_impulse, const Vector2& R,
                     const Vector2& u, double& f2, double& scale2) {
  const double lever2 = row.bound * row.bound;
  // no torque on a disc of radius zero (no normal impulse): the target is zero and so is the
  // residual, whatever the velocity; the open rows of a screened powder step are such
  if (!(R.isZero(0.0) && normal_impulse <= 0.0)) {
    const Vector2 f = R - rollingTarget(row, dimension, normal_impulse, R, u);
    f2 += f.squaredNorm() / lever2;
  }
  scale2 += std::max(R.squaredNorm(), (u / row.W(0, 0)).squaredNorm()) / lever2;
}
void rollingResidual(const ContactProblem& p, int c, double normal_impulse, const Vector2& R,
                     const Vector2& u, double& f2, double& scale2) {
  rollingResidual({p.rolling_bound[c], p.rolling_delassus[c]}, p.dimension, normal_impulse, R, u,
                  f2, scale2);
}

bool hasRollingRow(const ContactProblem& p, const std::vector<Vector2>* R, int c) {
  return R != nullptr && p.rolling && p.rolling_bound[c] > 0.0;
}

// Applies a warm start of the rolling rows; rows without a bound keep none.
// Row c's rolling torque into v, or cleared where the row has no rolling bound.
void warmStartRollingRow(const ContactProblem& p, std::vector<Vector2>& R, int c, VectorX& v) {
  if (p.rolling_bound[c] > 0.0)
    p.applyRolling(c, R[c], v);
  else
    R[c].setZero();
}

void warmStartRolling(const ContactProblem& p, std::vector<Vector2>* R, VectorX& v) {
  if (R == nullptr || !p.rolling) return;
  for (int c = 0; c < p.size(); ++c) warmStartRollingRow(p, *R, c, v);
}

// The warm start of rows order[0, count): their impulses into v, then their rolling torques.
void warmStart(const ContactProblem& p, const std::vector<Vector3>& P, std::vector<Vector2>* R,
               const int* order, int count, VectorX& v) {
  for (int k = 0; k < count; ++k) p.applyImpulse(order[k], P[order[k]], v);
  if (R == nullptr || !p.rolling) return;
  for (int k = 0; k < count; ++k) warmStartRollingRow(p, *R, order[k], v);
}

// The stats of a solve over islands: the worst island's sweeps, residual and status.
void mergeIsland(NlgsStats& total, const NlgsStats& island) {
  total.iterations = std::max(total.iterations, island.iterations);
  total.updates += island.updates;
  total.residual = std::max(total.residual, island.residual);
  total.local_failures += island.local_failures;
  if (island.status == SolverStatus::Failed ||
      (island.status == SolverStatus::MaxIterations && total.status == SolverStatus::Converged))
    total.status = island.status;
}

double relative(double num2, double den2) {
  return den2 > 0.0 ? std::sqrt(num2 / den2) : std::sqrt(num2);
}

// Whether to evaluate the residual after sweep `it` (from 0), whose impulse change is change2
// against size2.
bool residualDue(const NlgsSettings& settings, int it, double change2, double size2) {
  return relative(change2, size2) < settings.tolerance ||
         (settings.residual_check_interval > 0 && (it + 1) % settings.residual_check_interval == 0);
}

}  // namespace

// ---------------------------------------------------------------------------------------
// scheme A
// ---------------------------------------------------------------------------------------

namespace {
// Prefetches for update k of a sweep over compact sphere rows: the record of the row
// kSphereRecordAhead rows on, and the second sphere's velocity of the row kSphereVelocityAhead
// rows on, whose record is then in cache. The first sphere's velocities come in the rows'
// order, which the hardware prefetcher follows; the second's do not. On the wide powder bed
// the rows stream about a megabyte between two visits of one sphere, more than this core's
// L2, and the loads of v_b were the sweep's largest stall. The record's five lines are
// fetched as non-temporal: read once per sweep, they should not push v out of the caches
// (the sweeps' time fell by a sixth against a plain prefetch of its first line). No number
// changes.
constexpr int kSphereRecordAhead = 16, kSphereVelocityAhead = 8;
[[gnu::always_inline]] inline void prefetchSphereRow(const PackedRows3d& rows, const int* order,
                                                     int k, int n, const VectorX& v) {
  if (k + kSphereRecordAhead < n) {
    const int slot = rows.slot[order[k + kSphereRecordAhead]];
    if (slot < 0) {
      const char* record = reinterpret_cast<const char*>(&rows.spheres[-1 - slot]);
      for (int line = 0; line < 5; ++line) __builtin_prefetch(record + 64 * line, 0, 0);
    }
  }
  if (k + kSphereVelocityAhead < n) {
    const int slot = rows.slot[order[k + kSphereVelocityAhead]];
    if (slot < 0) {
      const int dof_b = rows.spheres[-1 - slot].dof_b;
      if (dof_b >= 0) {  // six velocities: one or two cache lines
        __builtin_prefetch(v.data() + dof_b);
        __builtin_prefetch(v.data() + dof_b + 5);
      }
    }
  }
}

// natural map with rho = 1 / W_NN per contact, so that the residual is an impulse and
// comparable to P (Siconos mixes impulses and velocities)
void coulombResidualTerms(const ContactProblem& p, const std::vector<Vector3>& P,
                          const std::vector<Vector2>* R, const VectorX& v, const int* order,
                          int count, double& f2, double& scale2);

// chunked: over the coloured sweeps' chunks on `threads` threads, the sums per chunk added in
// chunk order (the same bits for every thread count); otherwise over ws.order[0, count)
double coulombResidual(const ContactProblem& p, const std::vector<Vector3>& P,
                       const std::vector<Vector2>* R, const VectorX& v, NlgsWorkspace& ws,
                       int count, bool chunked = false, int threads = 1) {
  if (chunked) {
    const int chunks = ws.colour_chunk[kColours + 1];
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1)
    for (int chunk = 0; chunk < chunks; ++chunk) {
      const int first = ws.chunk_begin[chunk], last = ws.chunk_begin[chunk + 1];
      double f2 = 0.0, scale2 = 0.0;
      coulombResidualTerms(p, P, R, v, ws.order.data() + first, last - first, f2, scale2);
      ws.chunk_change2[chunk] = f2;
      ws.chunk_size2[chunk] = scale2;
    }
    double f2 = 0.0, scale2 = 0.0;
    for (int chunk = 0; chunk < chunks; ++chunk) {
      f2 += ws.chunk_change2[chunk];
      scale2 += ws.chunk_size2[chunk];
    }
    return relative(f2, scale2);
  }
  double f2 = 0.0, scale2 = 0.0;
  coulombResidualTerms(p, P, R, v, ws.order.data(), count, f2, scale2);
  return relative(f2, scale2);
}

// The residual's sums over the rows order[0, count)
void coulombResidualTerms(const ContactProblem& p, const std::vector<Vector3>& P,
                          const std::vector<Vector2>* R, const VectorX& v, const int* order,
                          int count, double& f2, double& scale2) {
  // packed 3D rows: one pass for the contact's and its rolling row's velocities, the same sums
  const bool packed3d = p.packed3dComplete();
  const PackedRows3d rows(p);
  // one row's terms from its velocities, W_NN, bias, mu and rolling row
  auto add = [&](int c, Vector3 u, const Vector2& u_rolling, double W_NN, double bias, double mu,
                 const RollingRow& rolling_row) {
    if (R != nullptr && p.rolling && rolling_row.bound > 0.0)
      rollingResidual(rolling_row, p.dimension, P[c].x(), (*R)[c], u_rolling, f2, scale2);
    u.x() += bias;
    const Vector3 ru = u / W_NN;
    if (p.isBilateral(c)) {  // the natural map of an equality: its velocity
      f2 += ru.x() * ru.x();
      scale2 += std::max(P[c].squaredNorm(), ru.squaredNorm());
      return;
    }
    // P = 0 with U*_N >= 0 meets the law: the cone's projection of -(U* + mu |U*_T| e_N) is
    // then zero in floating point too (U*_N + mu |U*_T| >= mu |U*_T|), and the map adds
    // nothing. A screened powder step's open rows, 40 % of its rows, skip the projection.
    if (!(P[c].isZero(0.0) && ru.x() >= 0.0))
      f2 += coulombNaturalMap(P[c], ru, mu, p.dimension).squaredNorm();
    scale2 += std::max(P[c].squaredNorm(), ru.squaredNorm());
  };
  static const Matrix2 kNoRolling = Matrix2::Identity();
  for (int k = 0; k < count; ++k) {
    const int c = order[k];
    Vector3 u;
    Vector2 u_rolling = Vector2::Zero();
    if (packed3d && rows.slot[c] < 0) {
      // a compact sphere row holds all the residual reads, with the bits of the arrays
      prefetchSphereRow(rows, order, k, count, v);
      const ContactProblem::PackedSphere3d& s = rows.spheres[-1 - rows.slot[c]];
      s.velocity(v, u, u_rolling);
      const Matrix2 W_r = Matrix2::Identity() * (s.inverse_inertia_a + s.inverse_inertia_b);
      add(c, u, u_rolling, s.W_N(), s.bias, s.mu, {s.rolling_bound, W_r});
      continue;
    }
    const bool rolling_row = hasRollingRow(p, R, c);
    if (packed3d) {
      packedRowVelocity3d(rows, c, v, u, u_rolling);
    } else {
      u = p.localVelocity(c, v);
      if (rolling_row) u_rolling = p.rollingVelocity(c, v);
    }
    add(c, u, u_rolling, p.delassus[c](0, 0), p.normal_bias[c], p.friction[c],
        rolling_row ? RollingRow{p.rolling_bound[c], p.rolling_delassus[c]}
                    : RollingRow{0.0, kNoRolling});
  }
}
}  // namespace

namespace {
NlgsStats coulombIsland(const ContactProblem& p, const NlgsSettings& settings,
                        std::vector<Vector3>& P, std::vector<Vector2>* R, VectorX& v,
                        NlgsWorkspace& ws, int n);
}  // namespace

NlgsStats solveCoulombNlgs(const ContactProblem& p, const NlgsSettings& settings,
                           std::vector<Vector3>& P, VectorX& v, NlgsWorkspace& ws,
                           std::vector<Vector2>* R) {
  NlgsStats total;
  if (p.size() == 0) return total;
  prepareNncg(settings, p, v, ws);
  for (int island = 0; island < p.islandCount(); ++island) {
    const int n = selectIsland(p, island, ws);
    NlgsStats island_stats = coulombIsland(p, settings, P, R, v, ws, n);
    island_stats.updates = static_cast<long>(island_stats.iterations) * n;
    mergeIsland(total, island_stats);
  }
  if (!v.allFinite()) total.status = SolverStatus::Failed;
  return total;
}

namespace {
// One 2D update on the packed rows: the same arithmetic as the generic path below.
inline void coulombUpdate2d(const ContactProblem::PackedRow2d& r,
                            const ContactProblem::PackedEntry2d* h,
                            const ContactProblem::PackedEntry2d* minv, double omega, Vector3& P,
                            VectorX& v, double& change2, double& size2, int& failures) {
  if (P.x() == 0.0 && P.y() == 0.0) {  // an open row that stays open: see coulombUpdate3d
    double u_normal = r.known.x();
    for (int k = r.begin; k < r.end; ++k) u_normal += h[k].normal * v[h[k].dof];
    if (u_normal + r.bias >= 0.0) return;
  }
  Vector2 u = r.known;
  for (int k = r.begin; k < r.end; ++k) u += Vector2(h[k].normal, h[k].tangent) * v[h[k].dof];
  const Vector2 P_old = P.head<2>();
  Vector2 q = u - r.W * P_old;
  q.x() += r.bias;
  Vector2 P_new;
  if (r.mu == 0.0) {
    P_new = Vector2(std::max(-q.x() * r.W_inverse(0, 0), 0.0), 0.0);
  } else if (!solveCoulomb2d(r.W, r.W_inverse, q, r.mu, P_new)) {
    ++failures;
  }
  P_new = relaxedImpulse(P_new, P_old, omega);
  const Vector2 dP = P_new - P_old;
  for (int k = r.minv_begin; k < r.minv_end; ++k)
    v[minv[k].dof] += minv[k].normal * dP.x() + minv[k].tangent * dP.y();
  P.head<2>() = P_new;
  change2 += dP.squaredNorm();
  size2 += P_new.squaredNorm();
}

// What coulombUpdate3d reads of a packed row, for each packed form: a PackedRow3d (with its
// entries or its body form) and a compact sphere row, whose W and W_r are diagonal.
struct GeneralRow3d {
  const ContactProblem::PackedRow3d& r;
  const PackedRows3d& s;
  double normalVelocity(const VectorX& v) const { return packedNormalVelocity3d(r, s, v); }
  void velocity(const VectorX& v, Vector3& u, Vector2& u_rolling) const {
    packedVelocity3d(r, s, v, u, u_rolling);
  }
  double bias() const { return r.bias; }
  double mu() const { return r.mu; }
  Vector3 freeVelocity(const Vector3& u, const Vector3& P) const { return u - r.W * P; }
  double normalInverse() const { return r.W_inverse(0, 0); }
  const Matrix3& W() const { return r.W; }
  const Matrix3& W_inverse() const { return r.W_inverse; }
  double rollingBound() const { return r.rolling_bound; }
  Vector2 rollingChange(const Vector3& dP) const { return r.rolling_coupling * dP; }
  double rollingIsotropicInverse() const { return r.rolling_isotropic_inverse; }
  const Matrix2& rollingW() const { return r.rolling_W; }
  void apply(const Vector3& dP, const Vector2& dR, VectorX& v) const {
    applyPacked3d(r, s, dP, dR, v);
  }
};
struct SphereRow3d {
  const ContactProblem::PackedSphere3d& r;
  double normalVelocity(const VectorX& v) const { return r.normalVelocity(v); }
  void velocity(const VectorX& v, Vector3& u, Vector2& u_rolling) const {
    r.velocity(v, u, u_rolling);
  }
  double bias() const { return r.bias; }
  double mu() const { return r.mu; }
  Vector3 freeVelocity(const Vector3& u, const Vector3& P) const {
    const double W_T = r.W_T();
    return Vector3(u.x() - r.W_N() * P.x(), u.y() - W_T * P.y(), u.z() - W_T * P.z());
  }
  double normalInverse() const { return r.normal_inverse; }
  Matrix3 W() const { return Vector3(r.W_N(), r.W_T(), r.W_T()).asDiagonal(); }
  Matrix3 W_inverse() const {
    return Vector3(r.normal_inverse, r.tangent_inverse, r.tangent_inverse).asDiagonal();
  }
  double rollingBound() const { return r.rolling_bound; }
  Vector2 rollingChange(const Vector3& dP) const {
    const double kappa = r.rollingCoupling();
    return Vector2(-kappa * dP.z(), kappa * dP.y());
  }
  double rollingIsotropicInverse() const { return r.rolling_inverse; }
  Matrix2 rollingW() const { return Matrix2::Identity() / r.rolling_inverse; }
  void apply(const Vector3& dP, const Vector2& dR, VectorX& v) const { r.apply(dP, dR, v); }
};

// One 3D update on a packed row, the rolling rows (when R is given) in the same pass: the
// same block Gauss-Seidel as the generic path below (contact first, then its rolling rows on
// the velocity the contact left), equal to it up to round-off.
template <class Row>
[[gnu::always_inline]] inline void coulombUpdate3d(const Row& r, double omega,
                                                   LocalSolver3d local_solver, Vector3& P,
                                                   Vector2* R, VectorX& v, double& change2,
                                                   double& size2, int& failures) {
  // An open row stays open: with P = 0 and R = 0 the local free velocity is U, and
  // U_N + bias >= 0 makes every local solver return P = 0 (then R's disc has radius 0). On a
  // screened powder pass 43 % of the updates are such rows; their normal velocity alone costs
  // a fifth of the full one. Its sum runs in the full loop's order, so nothing changes by a bit.
  if (P.isZero(0.0) && (R == nullptr || R->isZero(0.0) || r.rollingBound() == 0.0)) {
    if (r.normalVelocity(v) + r.bias() >= 0.0) return;
  }
  Vector3 u;
  Vector2 u_rolling;
  r.velocity(v, u, u_rolling);
  Vector3 q = r.freeVelocity(u, P);
  q.x() += r.bias();
  Vector3 P_new = Vector3::Zero();
  bool ok = true;
  if (r.mu() == 0.0)
    P_new.x() = std::max(-q.x() * r.normalInverse(), 0.0);
  else if (local_solver == LocalSolver3d::Enumeration)
    ok = solveCoulomb3d(r.W(), r.W_inverse(), q, r.mu(), P_new);
  else
    ok = solveCoulomb3dNewton(r.W(), r.W_inverse(), q, r.mu(), P, P_new);
  failures += ok ? 0 : 1;
  P_new = relaxedImpulse(P_new, P, omega);
  const Vector3 dP = P_new - P;
  P = P_new;
  change2 += dP.squaredNorm();
  size2 += P_new.squaredNorm();
  Vector2 dR = Vector2::Zero();
  if (R != nullptr && r.rollingBound() > 0.0) {
    u_rolling += r.rollingChange(dP);
    const double radius = r.rollingBound() * std::max(P_new.x(), 0.0);
    Vector2 target;
    if (r.rollingIsotropicInverse() > 0.0) {
      target = *R - u_rolling * r.rollingIsotropicInverse();
      const double norm2 = target.squaredNorm();
      if (norm2 > radius * radius) target *= radius / std::sqrt(norm2);
    } else {
      target = minimizeOnDisc(r.rollingW(), *R, u_rolling, radius);
    }
    dR = relaxedChange(target, *R, omega);
    *R += dR;
    const double lever2 = r.rollingBound() * r.rollingBound();
    change2 += dR.squaredNorm() / lever2;
    size2 += R->squaredNorm() / lever2;
  }
  r.apply(dP, dR, v);
}

constexpr double kNncgRestart = 1.5;

// One per-contact impulse array a solver sweeps: contact c owns data[c * width, + width).
struct ImpulseArray {
  double* data = nullptr;  // null: absent (no rolling rows)
  int width = 0;
};
static_assert(sizeof(Vector3) == 3 * sizeof(double) && sizeof(Vector2) == 2 * sizeof(double),
              "impulse vectors are read as packed doubles");
ImpulseArray impulses(std::vector<Vector3>& x) {
  return {x.data()->data(), 3};
}
ImpulseArray impulses(std::vector<Vector2>* x) {
  return x == nullptr || x->empty() ? ImpulseArray{} : ImpulseArray{x->data()->data(), 2};
}
ImpulseArray impulses(std::vector<double>& x) {
  return {x.data(), 1};
}

// NNCG bookkeeping over the island in ws.order[0, n): the dofs its rows move, and the
// iterate before the next sweep. The copies are stored by position in the island, so that
// the two passes per sweep stream through them.
class NncgMomentum {
 public:
  NncgMomentum(const ContactProblem& p, std::initializer_list<ImpulseArray> arrays,
               const VectorX& v, NlgsWorkspace& ws, int n, int threads = 1)
      : ws_(ws), n_(n), threads_(n >= kParallelMomentum ? threads : 1) {
    for (const ImpulseArray& array : arrays) {
      if (array.data == nullptr) continue;
      arrays_[array_count_++] = array;
    }
    if (++ws.stamp == 0) {  // wrapped: stamps from long ago could match again
      std::fill(ws.dof_stamp.begin(), ws.dof_stamp.end(), 0);
      ws.stamp = 1;
    }
    for (int k = 0; k < n; ++k) {
      const int c = ws.order[k];
      auto add = [&](int dof) {
        if (ws.dof_stamp[dof] == ws.stamp) return;
        ws.dof_stamp[dof] = ws.stamp;
        ws.island_dofs[dofs_++] = dof;
      };
      // the dofs a row's impulse moves: its M^-1 H entries, or its H entries if diagonal
      p.forEachMovedDof(c, add);
    }
    // in index order, so that the momentum's pass streams through v instead of gathering it
    // in the rows' order (on the wide powder bed, 40 % of that pass waited on the gather)
    const int nv = static_cast<int>(ws.dof_stamp.size());
    if (8L * dofs_ >= nv) {
      int j = 0;
      for (int dof = 0; dof < nv; ++dof)
        if (ws.dof_stamp[dof] == ws.stamp) ws.island_dofs[j++] = dof;
    } else {
      std::sort(ws.island_dofs.begin(), ws.island_dofs.begin() + dofs_);
    }
    const int width = rowWidth();
#pragma omp parallel for schedule(static) num_threads(threads_) if (threads_ > 1)
    for (int k = 0; k < n; ++k) {
      int slot = k * width;
      for (int a = 0; a < array_count_; ++a) {
        const double* x = arrays_[a].data + ws.order[k] * arrays_[a].width;
        for (int j = 0; j < arrays_[a].width; ++j, ++slot) {
          ws.impulse_before[slot] = x[j];
          ws.impulse_direction[slot] = 0.0;
        }
      }
    }
#pragma omp parallel for schedule(static) num_threads(threads_) if (threads_ > 1)
    for (int i = 0; i < dofs_; ++i) {
      ws.v_before[i] = v[ws.island_dofs[i]];
      ws.v_direction[i] = 0.0;
    }
  }

  // After a sweep whose own impulse change was change2 (in the solver's norm): the momentum
  // step, the new direction, and the snapshot for the next sweep.
  void step(double change2, VectorX& v) {
    double beta = previous_change2_ > 0.0 ? change2 / previous_change2_ : 0.0;
    // Restart along steepest descent once a sweep loses ground. Silcowitz-Hansen et al.
    // restart at beta > 1; with friction and rolling resistance the sweep's change is not
    // monotone even on the way to convergence, and on the powder heap that rule restarted
    // a third of the sweeps. 1.5 halved the sweeps again; 3 let the momentum run away
    // (docs/powder_bed.md, "NNCG").
    if (beta > kNncgRestart) beta = 0.0;
    previous_change2_ = change2;
    // element by element: any split between threads gives the same bits
    const int width = rowWidth();
#pragma omp parallel for schedule(static) num_threads(threads_) if (threads_ > 1)
    for (int k = 0; k < n_; ++k) {
      int slot = k * width;
      for (int a = 0; a < array_count_; ++a) {
        double* x = arrays_[a].data + ws_.order[k] * arrays_[a].width;
        for (int j = 0; j < arrays_[a].width; ++j, ++slot)
          advance(beta, x[j], ws_.impulse_before[slot], ws_.impulse_direction[slot]);
      }
    }
#pragma omp parallel for schedule(static) num_threads(threads_) if (threads_ > 1)
    for (int i = 0; i < dofs_; ++i)
      advance(beta, v[ws_.island_dofs[i]], ws_.v_before[i], ws_.v_direction[i]);
  }

 private:
  int rowWidth() const {
    int width = 0;
    for (int a = 0; a < array_count_; ++a) width += arrays_[a].width;
    return width;
  }
  // x holds GS(x_k); before holds x_k; direction holds p_{k-1}
  static void advance(double beta, double& x, double& before, double& direction) {
    const double sweep_change = x - before;
    x += beta * direction;
    direction = beta * direction + sweep_change;
    before = x;
  }

  // rows below which the momentum step stays on one thread
  static constexpr int kParallelMomentum = 4096;
  NlgsWorkspace& ws_;
  int n_;
  int threads_ = 1;
  ImpulseArray arrays_[3];
  int array_count_ = 0;
  int dofs_ = 0;
  double previous_change2_ = 0.0;
};

NlgsStats coulombIsland(const ContactProblem& p, const NlgsSettings& settings,
                        std::vector<Vector3>& P, std::vector<Vector2>* R, VectorX& v,
                        NlgsWorkspace& ws, int n) {
  NlgsStats stats;
  const double omega = settings.relaxation;
  const bool packed = p.dimension == 2 && static_cast<int>(p.rows2d.size()) == p.size();
  const bool packed3d =
      p.packed3dComplete() && (R == nullptr || static_cast<int>(R->size()) == p.size());
  const bool coloured = n >= settings.parallel_rows && !settings.shuffle && (packed || packed3d) &&
                        p.row_components.size() == static_cast<std::size_t>(p.size()) &&
                        ws.row_colour.size() >= static_cast<std::size_t>(n);
  // the warm start of the island's rows (the other islands move other velocities): a
  // coloured island's chunk by chunk, as its sweeps go
  if (coloured) {
    colourIsland(p, ws, n);
    forEachColourChunk(ws, settings.threads, [&](int chunk) {
      const int first = ws.chunk_begin[chunk], last = ws.chunk_begin[chunk + 1];
      warmStart(p, P, R, ws.order.data() + first, last - first, v);
    });
  } else {
    warmStart(p, P, R, ws.order.data(), n, v);
  }
  std::optional<NncgMomentum> momentum;
  if (settings.acceleration == NlgsAcceleration::Nncg)
    momentum.emplace(p, std::initializer_list<ImpulseArray>{impulses(P), impulses(R)}, v, ws, n,
                     coloured ? settings.threads : 1);
  const PackedRows3d rows3d(p);
  // one chunk of a coloured sweep, its sums kept apart
  const auto sweepChunk = [&](int chunk) {
    double change2 = 0.0, size2 = 0.0;
    int failures = 0;
    const int first = ws.chunk_begin[chunk], last = ws.chunk_begin[chunk + 1];
    for (int k = first; k < last; ++k) {
      const int c = ws.order[k];
      if (packed) {
        coulombUpdate2d(p.rows2d[c], p.h2d.data(), p.minv2d.data(), omega, P[c], v, change2, size2,
                        failures);
        continue;
      }
      prefetchSphereRow(rows3d, ws.order.data(), k, last, v);
      const int slot = rows3d.slot[c];
      Vector2* Rc = R != nullptr ? &(*R)[c] : nullptr;
      if (slot < 0)
        coulombUpdate3d(SphereRow3d{rows3d.spheres[-1 - slot]}, omega, settings.local_solver_3d,
                        P[c], Rc, v, change2, size2, failures);
      else
        coulombUpdate3d(GeneralRow3d{rows3d.rows[slot], rows3d}, omega, settings.local_solver_3d,
                        P[c], Rc, v, change2, size2, failures);
    }
    ws.chunk_change2[chunk] = change2;
    ws.chunk_size2[chunk] = size2;
    ws.chunk_failures[chunk] = failures;
  };
  for (int it = 0; it < settings.max_iterations; ++it) {
    nextOrder(settings, ws, it, n);
    double change2 = 0.0, size2 = 0.0;
    stats.local_failures = 0;
    if (coloured) {
      forEachColourChunk(ws, settings.threads, sweepChunk);
      for (int chunk = 0; chunk < ws.colour_chunk[kColours + 1]; ++chunk) {
        change2 += ws.chunk_change2[chunk];
        size2 += ws.chunk_size2[chunk];
        stats.local_failures += ws.chunk_failures[chunk];
      }
    } else if (packed) {
      for (int k = 0; k < n; ++k) {
        const int c = ws.order[k];
        coulombUpdate2d(p.rows2d[c], p.h2d.data(), p.minv2d.data(), omega, P[c], v, change2, size2,
                        stats.local_failures);
      }
    }
    if (packed3d && !coloured) {
      const PackedRows3d rows(p);
      for (int k = 0; k < n; ++k) {
        prefetchSphereRow(rows, ws.order.data(), k, n, v);
        const int c = ws.order[k];
        const int slot = rows.slot[c];
        Vector2* Rc = R != nullptr ? &(*R)[c] : nullptr;
        if (slot < 0)
          coulombUpdate3d(SphereRow3d{rows.spheres[-1 - slot]}, omega, settings.local_solver_3d,
                          P[c], Rc, v, change2, size2, stats.local_failures);
        else
          coulombUpdate3d(GeneralRow3d{rows.rows[slot], rows}, omega, settings.local_solver_3d,
                          P[c], Rc, v, change2, size2, stats.local_failures);
      }
    }
    for (int k = 0; k < (packed || packed3d ? 0 : n); ++k) {
      const int c = ws.order[k];
      const Matrix3& W = p.delassus[c];
      // local free velocity: the current one without this contact's own impulse
      Vector3 q = p.localVelocity(c, v) - W * P[c];
      q.x() += p.normal_bias[c];
      Vector3 P_new = Vector3::Zero();
      bool ok = true;
      if (p.friction[c] == 0.0) {
        P_new.x() = -q.x() * p.delassus_inverse[c](0, 0);
        if (!p.isBilateral(c)) P_new.x() = std::max(P_new.x(), 0.0);
      } else if (p.dimension == 2) {
        Vector2 P2;
        ok = solveCoulomb2d(W.topLeftCorner<2, 2>(), p.delassus_inverse[c].topLeftCorner<2, 2>(),
                            q.head<2>(), p.friction[c], P2);
        P_new.head<2>() = P2;
      } else {
        ok = settings.local_solver_3d == LocalSolver3d::Enumeration
                 ? solveCoulomb3d(W, p.delassus_inverse[c], q, p.friction[c], P_new)
                 : solveCoulomb3dNewton(W, p.delassus_inverse[c], q, p.friction[c], P[c], P_new);
      }
      stats.local_failures += ok ? 0 : 1;
      P_new = relaxedImpulse(P_new, P[c], omega);
      const Vector3 dP = P_new - P[c];
      p.applyImpulse(c, dP, v);
      P[c] = P_new;
      change2 += dP.squaredNorm();
      size2 += P_new.squaredNorm();
      if (hasRollingRow(p, R, c)) rollingUpdate(p, c, P_new.x(), omega, (*R)[c], v, change2, size2);
    }
    stats.iterations = it + 1;
    if (residualDue(settings, it, change2, size2)) {
      stats.residual = coulombResidual(p, P, R, v, ws, n, coloured, settings.threads);
      if (stats.residual < settings.tolerance) {
        stats.status = SolverStatus::Converged;
        return stats;
      }
    }
    // not after the last sweep: the impulses returned are a sweep's output
    if (momentum && it + 1 < settings.max_iterations) momentum->step(change2, v);
  }
  stats.residual = coulombResidual(p, P, R, v, ws, n, coloured, settings.threads);
  stats.status =
      stats.residual < settings.tolerance ? SolverStatus::Converged : SolverStatus::MaxIterations;
  return stats;
}
}  // namespace

// ---------------------------------------------------------------------------------------
// scheme B, stage 5a: normals scaled to unit M^-1 norm, s_c = sqrt(W_NN,c); Lambda = s lambda
// ---------------------------------------------------------------------------------------

namespace {
double normalResidual(const ContactProblem& p, const std::vector<double>& lambda_N,
                      const VectorX& v, const NlgsWorkspace& ws, int count) {
  double f2 = 0.0, scale2 = 0.0;
  for (int k = 0; k < count; ++k) {
    const int c = ws.order[k];
    const double s = std::sqrt(p.delassus[c](0, 0));
    const double xi = (p.localVelocity(c, v).x() + p.normal_bias[c]) / s;
    const double Lambda = s * lambda_N[c];
    const double f = p.isBilateral(c) ? xi : Lambda - std::max(Lambda - xi, 0.0);
    f2 += f * f;
    scale2 += std::max(Lambda * Lambda, xi * xi);
  }
  return relative(f2, scale2);
}
}  // namespace

namespace {
NlgsStats normalIsland(const ContactProblem& p, const NlgsSettings& settings,
                       std::vector<double>& lambda_N, VectorX& v, NlgsWorkspace& ws, int n);
}  // namespace

NlgsStats solveNormalStage(const ContactProblem& p, const NlgsSettings& settings,
                           std::vector<double>& lambda_N, VectorX& v, NlgsWorkspace& ws) {
  if (settings.solver != StageSolver::Nlgs)
    return solveNormalStageMprgp(p, settings, lambda_N, v, ws);
  NlgsStats total;
  for (int c = 0; c < p.size(); ++c) p.applyImpulse(c, Vector3(lambda_N[c], 0, 0), v);
  if (p.size() == 0) return total;
  prepareNncg(settings, p, v, ws);
  for (int island = 0; island < p.islandCount(); ++island) {
    const int n = selectIsland(p, island, ws);
    NlgsStats island_stats = normalIsland(p, settings, lambda_N, v, ws, n);
    island_stats.updates = static_cast<long>(island_stats.iterations) * n;
    mergeIsland(total, island_stats);
  }
  if (!v.allFinite()) total.status = SolverStatus::Failed;
  return total;
}

namespace {
NlgsStats normalIsland(const ContactProblem& p, const NlgsSettings& settings,
                       std::vector<double>& lambda_N, VectorX& v, NlgsWorkspace& ws, int n) {
  NlgsStats stats;
  const bool packed = p.dimension == 2 && static_cast<int>(p.rows2d.size()) == p.size();
  std::optional<NncgMomentum> momentum;
  if (settings.acceleration == NlgsAcceleration::Nncg)
    momentum.emplace(p, std::initializer_list<ImpulseArray>{impulses(lambda_N)}, v, ws, n);
  for (int it = 0; it < settings.max_iterations; ++it) {
    nextOrder(settings, ws, it, n);
    double change2 = 0.0, size2 = 0.0;
    if (packed) {
      // the update below on the packed 2D rows
      const ContactProblem::PackedEntry2d* h = p.h2d.data();
      const ContactProblem::PackedEntry2d* minv = p.minv2d.data();
      for (int k = 0; k < n; ++k) {
        const int c = ws.order[k];
        const ContactProblem::PackedRow2d& r = p.rows2d[c];
        double U_star = r.known.x() + r.bias;
        for (int e = r.begin; e < r.end; ++e) U_star += h[e].normal * v[h[e].dof];
        const double lambda_new =
            std::max(lambda_N[c] - settings.relaxation * U_star * r.normal_inverse, 0.0);
        const double d_lambda = lambda_new - lambda_N[c];
        for (int e = r.minv_begin; e < r.minv_end; ++e) v[minv[e].dof] += minv[e].normal * d_lambda;
        lambda_N[c] = lambda_new;
        const double W_NN = r.W(0, 0);
        change2 += W_NN * d_lambda * d_lambda;
        size2 += W_NN * lambda_new * lambda_new;
      }
    }
    for (int k = 0; k < (packed ? 0 : n); ++k) {
      const int c = ws.order[k];
      // unit diagonal in the scaled variables Lambda = s lambda, xi = U*_N / s (s^2 = W_NN):
      // Lambda <- [Lambda - omega xi]_+ is, in physical units, the clamp below
      const double W_NN = p.delassus[c](0, 0);
      const double U_star = p.localVelocity(c, v).x() + p.normal_bias[c];
      double lambda_new =
          lambda_N[c] - settings.relaxation * U_star * p.normal_compliance_inverse[c];
      if (!p.isBilateral(c)) lambda_new = std::max(lambda_new, 0.0);
      const double d_lambda = lambda_new - lambda_N[c];
      p.applyImpulse(c, Vector3(d_lambda, 0, 0), v);
      lambda_N[c] = lambda_new;
      change2 += W_NN * d_lambda * d_lambda;
      size2 += W_NN * lambda_new * lambda_new;
    }
    stats.iterations = it + 1;
    if (residualDue(settings, it, change2, size2)) {
      stats.residual = normalResidual(p, lambda_N, v, ws, n);
      if (stats.residual < settings.tolerance) return stats;
    }
    if (momentum && it + 1 < settings.max_iterations) momentum->step(change2, v);
  }
  stats.residual = normalResidual(p, lambda_N, v, ws, n);
  stats.status =
      stats.residual < settings.tolerance ? SolverStatus::Converged : SolverStatus::MaxIterations;
  return stats;
}
}  // namespace

// ---------------------------------------------------------------------------------------
// scheme B, stage 5b
// ---------------------------------------------------------------------------------------

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
                          NlgsWorkspace& ws) {
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

NlgsStats solveFrictionStage(const ContactProblem& p, const NlgsSettings& settings,
                             const FrictionStageOptions& options,
                             const std::vector<double>& lambda_N, std::vector<double>& delta,
                             std::vector<Vector2>& lambda_T, VectorX& v, NlgsWorkspace& ws,
                             std::vector<Vector2>* R,
                             const std::vector<double>* threshold_impulse) {
  if (settings.solver != StageSolver::Nlgs)
    return solveFrictionStageMpgp(p, settings, options, lambda_N, delta, lambda_T, v, ws, R,
                                  threshold_impulse);
  NlgsStats stats;
  const int n = p.size();
  const int dT = p.dimension - 1;
  // thresholds frozen from stage 5a; the normal velocities of closed contacts (GLOBAL)
  // are held at their stage-5a values
  prepareFrictionStage(p, options, lambda_N, threshold_impulse, v, ws);
  // GLOBAL mode holds the normal velocity of every contact closed by stage 5a (lambda_N > 0),
  // frictionless ones (mu = 0 pairs, joint limits) included: friction elsewhere must not
  // push them open or closed
  // (a bilateral row is held whatever the sign of its impulse)
  auto closed = [&](int c) { return lambda_N[c] > 0.0 || p.isBilateral(c); };
  auto held = [&](int c) { return options.tangents == TangentMode::Global && closed(c); };
  // The other rows keep stage 5a's normal law, U_N + bias >= 0 _|_ delta >= 0
  // (OpenContacts::Unilateral): without it, friction at the held rows drives bodies into the
  // contacts 5a left open, and under VEL nothing pushes them out again. In a deep powder heap
  // that overlap grew to 38 um (docs/schemes.md, "Open contacts in stage 5b").
  auto guarded = [&](int c) {
    return options.tangents == TangentMode::Global &&
           options.open_contacts == OpenContacts::Unilateral && !closed(c);
  };
  // a guarded row's projected Gauss-Seidel step on delta, at normal velocity u_N: updates
  // delta and the sweep's measures, returns the change (v is the caller's to update)
  auto guardStep = [&](int c, double u_N, double W_NN, double& change2, double& size2) {
    const double target = std::max(delta[c] - (u_N + p.normal_bias[c]) / W_NN, 0.0);
    const double dd =
        std::max(delta[c] + settings.relaxation * (target - delta[c]), 0.0) - delta[c];
    delta[c] += dd;
    change2 += dd * dd;
    size2 += delta[c] * delta[c];
    return dd;
  };
  auto tangentMap = [&](int c, const Vector2& dl) {
    // impulse in (normal, tangents) whose generalized force is the chosen tangent times dl
    // in 2D the second tangent component of dl and of the coupling is zero
    Vector3 dP(0.0, dl.x(), dT == 2 ? dl.y() : 0.0);
    if (options.tangents == TangentMode::Local) dP.x() = -ws.coupling[c].dot(dl);
    return dP;
  };
  // Friction acts on the tangential part of the motion, W_T^T (v - v_N), with v_N the
  // M-projection of v1 on the span of the closed normals: v_N = M^-1 N_A y,
  // (N_A^T M^-1 N_A) y = N_A^T v1 (reference 4.3, 5b). It is zero for e = 0 with VEL, and
  // is what keeps KE(v2) <= KE(v1) otherwise. Solved by Gauss-Seidel on the closed set.
  std::fill(ws.offset.begin(), ws.offset.end(), Vector2::Zero());
  bool needs_projection = false;
  // With U*_N = U_N (e = 0, VEL) the closed contacts have U_N = 0 after stage 5a, up to the
  // tolerance, and v_N vanishes: skipped
  for (int c = 0; c < n; ++c)
    needs_projection = needs_projection || (closed(c) && p.normal_bias[c] != 0.0);
  if (options.tangents == TangentMode::Global && needs_projection) {
    if (ws.v_normal.size() < v.size()) ws.v_normal.resize(v.size());
    ws.v_normal.setZero();
    std::fill(ws.y.begin(), ws.y.end(), 0.0);
    for (int sweep_count = 0; sweep_count < settings.max_iterations; ++sweep_count) {
      double change2 = 0.0, size2 = 0.0;
      for (int c = 0; c < n; ++c) {
        if (!closed(c)) continue;
        // residual of W_N^T v_N = W_N^T v1 (the known term cancels)
        const double r = ws.held_normal[c] - p.localVelocity(c, ws.v_normal).x();
        const double dy = r / p.delassus[c](0, 0);
        p.applyImpulse(c, Vector3(dy, 0, 0), ws.v_normal);
        ws.y[c] += dy;
        change2 += dy * dy;
        size2 += ws.y[c] * ws.y[c];
      }
      if (relative(change2, size2) < settings.tolerance) break;
    }
    for (int c = 0; c < n; ++c) {
      const Vector3 u = p.localVelocity(c, ws.v_normal) - p.known[c];
      ws.offset[c] = Vector2(u.y(), u.z());
    }
  }
  bool any = false;
  for (int c = 0; c < n; ++c)
    any = any || ws.threshold[c] > 0.0 || (hasRollingRow(p, R, c) && lambda_N[c] > 0.0);
  for (int c = 0; c < n; ++c) {
    // a warm start must be admissible: contacts without threshold carry no friction, and
    // the sweep skips them, so nothing may be left on them; a guarded row pushes only, and
    // only when something can move it (no sweep runs otherwise)
    if (guarded(c))
      delta[c] = any ? std::max(delta[c], 0.0) : 0.0;
    else if (!held(c))
      delta[c] = 0.0;
    if (ws.threshold[c] <= 0.0) lambda_T[c].setZero();
    Vector3 warm = tangentMap(c, lambda_T[c]);
    warm.x() += delta[c];
    p.applyImpulse(c, warm, v);
  }
  warmStartRolling(p, R, v);
  if (!any) return stats;

  // The tangential velocity the local problem acts on, its operator A, and (GLOBAL) the held
  // row's normal drift from its stage-5a velocity; true when the row is held (bilateral).
  auto tangentialPart = [&](int c, const Vector3& u, const Matrix3& W, Vector2& uT, Matrix2& A,
                            double& drift) {
    const Vector2& coupling = ws.coupling[c];
    uT = Vector2(u.y(), dT == 2 ? u.z() : 0.0) - ws.offset[c];
    A = ws.schur[c];
    drift = 0.0;
    switch (options.tangents) {
      case TangentMode::Global:
        drift = u.x() - ws.held_normal[c];
        // eliminating the normal correction leaves the Schur complement
        uT -= coupling * drift;
        return held(c);
      case TangentMode::Local:
        uT -= coupling * u.x();
        return false;
      case TangentMode::None:
        A = W.block<2, 2>(1, 1);
        if (p.dimension == 2) {
          A(0, 1) = A(1, 0) = 0.0;
          A(1, 1) = 1.0;
        }
        return false;
    }
    return false;
  };
  int count = 0;  // rows of the current island, in ws.order
  const bool packed = p.dimension == 2 && static_cast<int>(p.rows2d.size()) == p.size();
  // The update below on the packed 2D rows: one tangent, so the local problem is a clamp
  auto packedSweep = [&](double& change2, double& size2) {
    const ContactProblem::PackedEntry2d* h = p.h2d.data();
    const ContactProblem::PackedEntry2d* minv = p.minv2d.data();
    const double omega = settings.relaxation;
    for (int k = 0; k < count; ++k) {
      const int c = ws.order[k];
      const double radius = ws.threshold[c];
      const bool guard_row = guarded(c);
      if (radius <= 0.0 && !held(c) && !guard_row) continue;
      const ContactProblem::PackedRow2d& r = p.rows2d[c];
      Vector2 u = r.known;
      for (int e = r.begin; e < r.end; ++e) u += Vector2(h[e].normal, h[e].tangent) * v[h[e].dof];
      if (guard_row) {
        const double dd = guardStep(c, u.x(), r.W(0, 0), change2, size2);
        for (int e = r.minv_begin; e < r.minv_end; ++e) v[minv[e].dof] += minv[e].normal * dd;
        continue;
      }
      const double coupling = ws.coupling[c].x();
      double uT = u.y() - ws.offset[c].x();
      double A = ws.schur[c](0, 0);
      double drift = 0.0;
      if (options.tangents == TangentMode::Global) {
        drift = u.x() - ws.held_normal[c];
        uT -= coupling * drift;
      } else if (options.tangents == TangentMode::Local) {
        uT -= coupling * u.x();
      } else {
        A = r.W(1, 1);
      }
      const double lambda = lambda_T[c].x();
      const double dl = omega * (std::clamp(lambda - uT / A, -radius, radius) - lambda);
      double dN = options.tangents == TangentMode::Local ? -coupling * dl : 0.0;
      if (held(c)) {
        const double dd = -(drift + r.W(0, 1) * dl) * r.normal_inverse;
        dN += dd;
        delta[c] += dd;
      }
      for (int e = r.minv_begin; e < r.minv_end; ++e)
        v[minv[e].dof] += minv[e].normal * dN + minv[e].tangent * dl;
      lambda_T[c].x() = lambda + dl;
      change2 += dN * dN + dl * dl;
      size2 += (lambda + dl) * (lambda + dl) + delta[c] * delta[c];
    }
  };
  // 3D: one pass reads the contact's and its rolling row's velocities and one writes v, where
  // the generic rows below take four. The rolling row is updated first, as there, and its
  // effect on the contact's velocity is H_c^T M^-1 H_r dR = rolling_coupling^T dR.
  // (compact sphere rows take the generic path here: scheme B reads their W's blocks)
  const bool packed3d = p.packed3dComplete() && p.spheres3d.empty() &&
                        options.threshold == FrictionThreshold::Physical &&
                        (R == nullptr || static_cast<int>(R->size()) == p.size());
  auto packedSweep3d = [&](double& change2, double& size2) {
    const PackedRows3d rows(p);
    const double omega = settings.relaxation;
    for (int k = 0; k < count; ++k) {
      const int c = ws.order[k];
      const bool rolling_row = hasRollingRow(p, R, c);
      const bool friction_row = ws.threshold[c] > 0.0 || held(c);
      const bool guard_row = guarded(c);
      if (!rolling_row && !friction_row && !guard_row) continue;
      const ContactProblem::PackedRow3d& r = rows.rows[c];
      Vector3 u;
      Vector2 u_rolling;
      packedVelocity3d(r, rows, v, u, u_rolling);
      Vector2 dR = Vector2::Zero();
      if (rolling_row) {
        dR = rollingStep(p, c, lambda_N[c], omega, u_rolling, (*R)[c], change2, size2);
        u += r.rolling_coupling.transpose() * dR;
      }
      Vector3 dP = Vector3::Zero();
      if (friction_row) {
        Vector2 uT;
        Matrix2 A;
        double drift;
        const bool bilateral = tangentialPart(c, u, r.W, uT, A, drift);
        const Vector2 dl =
            omega * (minimizeOnDisc(A, lambda_T[c], uT, ws.threshold[c]) - lambda_T[c]);
        dP = tangentMap(c, dl);
        if (bilateral) {
          const double dd = -(drift + r.W.block<1, 2>(0, 1).dot(dl)) / r.W(0, 0);
          dP.x() += dd;
          delta[c] += dd;
        }
        lambda_T[c] += dl;
        change2 += dP.squaredNorm();
        size2 += lambda_T[c].squaredNorm() + delta[c] * delta[c];
      } else if (guard_row) {
        dP.x() = guardStep(c, u.x(), r.W(0, 0), change2, size2);
      }
      applyPacked3d(r, rows, dP, dR, v);
    }
  };
  auto sweep = [&](bool residual_only, double& change2, double& size2) {
    if (packed && !residual_only) {
      packedSweep(change2, size2);
      return 0.0;
    }
    if (packed3d && !residual_only) {
      packedSweep3d(change2, size2);
      return 0.0;
    }
    double f2 = 0.0, scale2 = 0.0;
    for (int k = 0; k < count; ++k) {
      const int c = ws.order[k];
      // rolling resistance, bounded by the stage-5a normal impulse like the friction
      if (hasRollingRow(p, R, c)) {
        if (residual_only)
          rollingResidual(p, c, lambda_N[c], (*R)[c], p.rollingVelocity(c, v), f2, scale2);
        else
          rollingUpdate(p, c, lambda_N[c], settings.relaxation, (*R)[c], v, change2, size2);
      }
      if (guarded(c)) {
        const double W_NN = p.delassus[c](0, 0);
        const double u_N = p.localVelocity(c, v).x();
        if (residual_only) {
          // the natural map of the unilateral row, an impulse as in scheme A's residual
          const double xi = (u_N + p.normal_bias[c]) / W_NN;
          const double f = delta[c] - std::max(delta[c] - xi, 0.0);
          f2 += f * f;
          scale2 += std::max(delta[c] * delta[c], xi * xi);
          continue;
        }
        p.applyImpulse(c, Vector3(guardStep(c, u_N, W_NN, change2, size2), 0.0, 0.0), v);
        continue;
      }
      if (ws.threshold[c] <= 0.0 && !held(c)) continue;
      const Matrix3& W = p.delassus[c];
      Vector2 uT;
      Matrix2 A;
      double drift;
      const bool bilateral = tangentialPart(c, p.localVelocity(c, v), W, uT, A, drift);
      double radius = ws.threshold[c];
      Vector2 target;
      if (p.dimension == 2) {
        target = Vector2(std::clamp(lambda_T[c].x() - uT.x() / A(0, 0), -radius, radius), 0.0);
      } else if (options.threshold == FrictionThreshold::Metric) {
        // ellipse lambda^T W_TT lambda <= (mu lambda_N)^2 W_NN: a disc in z = L^T lambda
        const Eigen::LLT<Matrix2> L(W.block<2, 2>(1, 1));
        const Matrix2 Lt = L.matrixU();
        const Matrix2 Lt_inv = Lt.inverse();
        radius *= std::sqrt(W(0, 0));
        const Vector2 z = minimizeOnDisc(Lt_inv.transpose() * A * Lt_inv, Lt * lambda_T[c],
                                         Lt_inv.transpose() * uT, radius);
        target = Lt_inv * z;
      } else {
        target = minimizeOnDisc(A, lambda_T[c], uT, radius);
      }
      if (residual_only) {
        const Vector2 f = lambda_T[c] - target;
        f2 += f.squaredNorm() + (bilateral ? drift * drift / (W(0, 0) * W(0, 0)) : 0.0);
        scale2 += std::max(lambda_T[c].squaredNorm(), (uT / A(0, 0)).squaredNorm());
        // the held normal row's residual is measured against the impulse that row carries,
        // as scheme A's natural map measures it against P_N
        if (bilateral && options.residual_scale_with_normal) {
          const double normal = lambda_N[c] + delta[c];
          scale2 += normal * normal;
        }
        continue;
      }
      const Vector2 dl = settings.relaxation * (target - lambda_T[c]);
      Vector3 dP = tangentMap(c, dl);
      if (bilateral) {
        // keep this contact's normal velocity at its stage-5a value
        const double dd = -(drift + W.block<1, 2>(0, 1).dot(dl)) / W(0, 0);
        dP.x() += dd;
        delta[c] += dd;
      }
      p.applyImpulse(c, dP, v);
      lambda_T[c] += dl;
      change2 += dP.squaredNorm();
      size2 += lambda_T[c].squaredNorm() + delta[c] * delta[c];
    }
    return relative(f2, scale2);
  };

  NlgsStats total;
  prepareNncg(settings, p, v, ws);
  for (int island = 0; island < p.islandCount(); ++island) {
    count = selectIsland(p, island, ws);
    NlgsStats island_stats;
    std::optional<NncgMomentum> momentum;
    if (settings.acceleration == NlgsAcceleration::Nncg)
      momentum.emplace(
          p, std::initializer_list<ImpulseArray>{impulses(&lambda_T), impulses(delta), impulses(R)},
          v, ws, count);
    for (int it = 0; it < settings.max_iterations; ++it) {
      nextOrder(settings, ws, it, count);
      double change2 = 0.0, size2 = 0.0;
      sweep(false, change2, size2);
      island_stats.iterations = it + 1;
      // the periodic check as in the other stages: with GLOBAL tangents in a hyperstatic heap
      // the bilateral corrections drift along redundant rows while the friction law is met
      if (residualDue(settings, it, change2, size2)) {
        island_stats.residual = sweep(true, change2, size2);
        if (island_stats.residual < settings.tolerance) break;
      }
      if (momentum && it + 1 < settings.max_iterations) momentum->step(change2, v);
    }
    if (island_stats.iterations == settings.max_iterations) {
      double change2 = 0.0, size2 = 0.0;
      island_stats.residual = sweep(true, change2, size2);
    }
    island_stats.updates = static_cast<long>(island_stats.iterations) * count;
    island_stats.status = island_stats.residual < settings.tolerance ? SolverStatus::Converged
                                                                     : SolverStatus::MaxIterations;
    mergeIsland(total, island_stats);
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
