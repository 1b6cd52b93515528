#pragma once
// The machinery of the Gauss-Seidel sweeps that the three NLGS solvers (integrators/nlgs.hpp)
// share: the row order of a sweep (islands, seeded shuffles, colours for threads), the NNCG
// momentum, relaxation, the rolling rows' local solve, the exit tests and the statistics over
// islands. Internal to integrators/.
#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <optional>

#include "framework/parallel.hpp"
#include "integrators/contact_problem.hpp"
#include "integrators/solver_settings.hpp"
#include "integrators/solver_workspace.hpp"

namespace sweep {

// The order of the next sweep over ws.order[0, count): the rows' own, or a seeded shuffle.
void nextOrder(const SolverSettings& settings, SolverWorkspace& ws, int iteration, int count);

// Cuts the island's rows ws.order[0, n) into blocks of kColourChunk consecutive rows and
// colours the blocks: a block takes the lowest colour free at every component its rows move,
// so that blocks of one colour share no velocity. The rows are then reordered block by block,
// colour after colour; a block keeps its rows' order (and their locality: rows come in
// detection order, and most blocks are a patch of the scene). Blocks beyond 64 colours, or
// with a row that moves more than two components, go to the last colour, swept by one thread.
void colourIsland(const ContactProblem& p, SolverWorkspace& ws, int n);

// Runs sweep(chunk) on every chunk, colour after colour; the chunks of one colour on
// `threads` threads. One parallel region per call, a barrier per colour.
template <class Sweep>
void forEachColourChunk(const SolverWorkspace& ws, int threads, Sweep&& sweep) {
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
void prepareNncg(const SolverSettings& settings, const ContactProblem& p, const VectorX& v,
                 SolverWorkspace& ws);

// Puts the rows of island i in ws.order[0, count) and returns count.
int selectIsland(const ContactProblem& p, int island, SolverWorkspace& ws);

// argmin over |y| <= radius of 1/2 (y - y0)^T A (y - y0) + b^T (y - y0), A SPD 2x2: the
// unconstrained minimizer, or the boundary point where (A + nu I) y = A y0 - b, nu >= 0,
// found by bisection on nu (|y(nu)| decreases with nu).
inline Vector2 minimizeOnDisc(const Matrix2& A, const Vector2& y0, const Vector2& b,
                              double radius) {
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
inline Vector2 rollingTarget(const RollingRow& row, int dimension, double normal_impulse,
                             const Vector2& R, const Vector2& u) {
  const double radius = row.bound * std::max(normal_impulse, 0.0);
  const Matrix2& W = row.W;
  if (dimension == 2) return Vector2(std::clamp(R.x() - u.x() / W(0, 0), -radius, radius), 0.0);
  return minimizeOnDisc(W, R, u, radius);
}
inline Vector2 rollingTarget(const ContactProblem& p, int c, double normal_impulse,
                             const Vector2& R, const Vector2& u) {
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
inline Vector2 rollingStep(const ContactProblem& p, int c, double normal_impulse, double omega,
                           const Vector2& u, Vector2& R, double& change2, double& size2) {
  const Vector2 dR = relaxedChange(rollingTarget(p, c, normal_impulse, R, u), R, omega);
  R += dR;
  const double lever2 = p.rolling_bound[c] * p.rolling_bound[c];
  change2 += dR.squaredNorm() / lever2;
  size2 += R.squaredNorm() / lever2;
  return dR;
}

inline void rollingUpdate(const ContactProblem& p, int c, double normal_impulse, double omega,
                          Vector2& R, VectorX& v, double& change2, double& size2) {
  const Vector2 u = p.rollingVelocity(c, v);
  p.applyRolling(c, rollingStep(p, c, normal_impulse, omega, u, R, change2, size2), v);
}

// natural-map residual of the rolling rows, in the same units
inline void rollingResidual(const RollingRow& row, int dimension, double normal_impulse,
                            const Vector2& R, const Vector2& u, double& f2, double& scale2) {
  const double lever2 = row.bound * row.bound;
  // no torque on a disc of radius zero (no normal impulse): the target is zero and so is the
  // residual, whatever the velocity; the open rows of a screened powder step are such
  if (!(R.isZero(0.0) && normal_impulse <= 0.0)) {
    const Vector2 f = R - rollingTarget(row, dimension, normal_impulse, R, u);
    f2 += f.squaredNorm() / lever2;
  }
  scale2 += std::max(R.squaredNorm(), (u / row.W(0, 0)).squaredNorm()) / lever2;
}
inline void rollingResidual(const ContactProblem& p, int c, double normal_impulse, const Vector2& R,
                            const Vector2& u, double& f2, double& scale2) {
  rollingResidual({p.rolling_bound[c], p.rolling_delassus[c]}, p.dimension, normal_impulse, R, u,
                  f2, scale2);
}

inline bool hasRollingRow(const ContactProblem& p, const std::vector<Vector2>* R, int c) {
  return R != nullptr && p.rolling && p.rolling_bound[c] > 0.0;
}

// Row c's rolling torque into v, or cleared where the row has no rolling bound.
void warmStartRollingRow(const ContactProblem& p, std::vector<Vector2>& R, int c, VectorX& v);
// Applies a warm start of the rolling rows; rows without a bound keep none.
void warmStartRolling(const ContactProblem& p, std::vector<Vector2>* R, VectorX& v);
// The warm start of rows order[0, count): their impulses into v, then their rolling torques.
void warmStart(const ContactProblem& p, const std::vector<Vector3>& P, std::vector<Vector2>* R,
               const int* order, int count, VectorX& v);

// The stats of a solve over islands: the worst island's sweeps, residual and status.
void mergeIsland(SolverStats& total, const SolverStats& island);

inline double relative(double num2, double den2) {
  return den2 > 0.0 ? std::sqrt(num2 / den2) : std::sqrt(num2);
}

// Whether to evaluate the residual after sweep `it` (from 0), whose impulse change is change2
// against size2.
inline bool residualDue(const SolverSettings& settings, int it, double change2, double size2) {
  return relative(change2, size2) < settings.tolerance ||
         (settings.residual_check_interval > 0 && (it + 1) % settings.residual_check_interval == 0);
}

constexpr double kNncgRestart = 1.5;
// the residual's growth past its least that drops the NNCG momentum (NncgMomentum::watch)
constexpr double kNncgRunaway = 100.0;

// One per-contact impulse array a solver sweeps: contact c owns data[c * width, + width).
struct ImpulseArray {
  double* data = nullptr;  // null: absent (no rolling rows)
  int width = 0;
};
static_assert(sizeof(Vector3) == 3 * sizeof(double) && sizeof(Vector2) == 2 * sizeof(double),
              "impulse vectors are read as packed doubles");
inline ImpulseArray impulses(std::vector<Vector3>& x) {
  return {x.data()->data(), 3};
}
inline ImpulseArray impulses(std::vector<Vector2>* x) {
  return x == nullptr || x->empty() ? ImpulseArray{} : ImpulseArray{x->data()->data(), 2};
}
inline ImpulseArray impulses(std::vector<double>& x) {
  return {x.data(), 1};
}

// NNCG bookkeeping over the island in ws.order[0, n): the dofs its rows move, and the
// iterate before the next sweep. The copies are stored by position in the island, so that
// the two passes per sweep stream through them.
class NncgMomentum {
 public:
  NncgMomentum(const ContactProblem& p, std::initializer_list<ImpulseArray> arrays,
               const VectorX& v, SolverWorkspace& ws, int n, int threads = 1)
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
    // slot k is row order[k] as the solve starts: a shuffled sweep order moves order, not
    // the slots (keyed by position, a shuffle mixed the rows' impulses with others')
    std::copy(ws.order.begin(), ws.order.begin() + n, ws.momentum_rows.begin());
    const int width = rowWidth();
    parallelFor(n, threads_, [&](int k) {
      int slot = k * width;
      for (int a = 0; a < array_count_; ++a) {
        const double* x = arrays_[a].data + ws.momentum_rows[k] * arrays_[a].width;
        for (int j = 0; j < arrays_[a].width; ++j, ++slot) {
          ws.impulse_before[slot] = x[j];
          ws.impulse_direction[slot] = 0.0;
        }
      }
    });
    parallelFor(dofs_, threads_, [&](int i) {
      ws.v_before[i] = v[ws.island_dofs[i]];
      ws.v_direction[i] = 0.0;
    });
  }

  // The residual at a check: once it has grown kNncgRunaway times past the least one seen (or
  // is not a number), the momentum is dropped for the rest of the solve and plain sweeps go on
  // from there. The momentum step is not projected: a run of bad steps can carry the impulses
  // off faster than the sweeps bring them back.
  void watch(double residual) {
    if (!(residual <= kNncgRunaway * least_residual_)) stopped_ = true;
    least_residual_ = std::min(least_residual_, residual);
  }
  bool stopped() const { return stopped_; }

  // After a sweep whose own impulse change was change2 (in the solver's norm): the momentum
  // step, the new direction, and the snapshot for the next sweep.
  void step(double change2, VectorX& v) {
    if (stopped_) return;
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
    parallelFor(n_, threads_, [&](int k) {
      int slot = k * width;
      for (int a = 0; a < array_count_; ++a) {
        double* x = arrays_[a].data + ws_.momentum_rows[k] * arrays_[a].width;
        for (int j = 0; j < arrays_[a].width; ++j, ++slot)
          advance(beta, x[j], ws_.impulse_before[slot], ws_.impulse_direction[slot]);
      }
    });
    parallelFor(dofs_, threads_, [&](int i) {
      advance(beta, v[ws_.island_dofs[i]], ws_.v_before[i], ws_.v_direction[i]);
    });
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
  SolverWorkspace& ws_;
  int n_;
  int threads_ = 1;
  ImpulseArray arrays_[3];
  int array_count_ = 0;
  int dofs_ = 0;
  double previous_change2_ = 0.0;
  double least_residual_ = std::numeric_limits<double>::infinity();
  bool stopped_ = false;
};

// Colours the island ws.order[0, n) (colourIsland) where it is swept in colour order on
// settings.threads threads: large enough (settings.parallel_rows), unshuffled, on packed rows
// whose components are known; returns whether it did. The colour order is taken for every
// thread count, so the bits do not depend on it.
inline bool colourForThreads(const ContactProblem& p, const SolverSettings& settings,
                             bool packed_rows, SolverWorkspace& ws, int n) {
  if (n < settings.parallel_rows || settings.shuffle || !packed_rows ||
      p.row_components.size() != static_cast<std::size_t>(p.size()) ||
      ws.row_colour.size() < static_cast<std::size_t>(n))
    return false;
  colourIsland(p, ws, n);
  return true;
}

// The sweeps of one island, ws.order[0, n), to the tolerance or the cap: the loop the three
// NLGS solvers share, from their warm start in v and momentum_impulses.
// sweep(first, last, change2, size2, failures) updates the rows ws.order[first, last) once
// each, in order; residual(first, last, f2, scale2) adds their residual's terms. `coloured`
// (colourForThreads): the chunks of one colour on settings.threads threads, every sum taken
// per chunk and added in chunk order. With NNCG (settings.acceleration) its momentum on
// momentum_impulses after each sweep but the last, so that the impulses returned are a sweep's.
template <class Sweep, class Residual>
SolverStats sweepIsland(const ContactProblem& p, const SolverSettings& settings,
                        SolverWorkspace& ws, int n, bool coloured,
                        std::initializer_list<ImpulseArray> momentum_impulses, VectorX& v,
                        Sweep&& sweep, Residual&& residual) {
  std::optional<NncgMomentum> momentum;
  if (settings.acceleration == NlgsAcceleration::Nncg)
    momentum.emplace(p, momentum_impulses, v, ws, n, coloured ? settings.threads : 1);
  const int chunks = coloured ? ws.colour_chunk[kColours + 1] : 0;
  auto residualNow = [&] {
    double f2 = 0.0, scale2 = 0.0;
    if (!coloured) {
      residual(0, n, f2, scale2);
      return relative(f2, scale2);
    }
    parallelFor(chunks, settings.threads, [&](int chunk) {
      double chunk_f2 = 0.0, chunk_scale2 = 0.0;
      residual(ws.chunk_begin[chunk], ws.chunk_begin[chunk + 1], chunk_f2, chunk_scale2);
      ws.chunk_change2[chunk] = chunk_f2;
      ws.chunk_size2[chunk] = chunk_scale2;
    });
    for (int chunk = 0; chunk < chunks; ++chunk) {
      f2 += ws.chunk_change2[chunk];
      scale2 += ws.chunk_size2[chunk];
    }
    return relative(f2, scale2);
  };
  SolverStats stats;
  for (int it = 0; it < settings.max_iterations; ++it) {
    nextOrder(settings, ws, it, n);
    double change2 = 0.0, size2 = 0.0;
    stats.local_failures = 0;
    if (coloured) {
      forEachColourChunk(ws, settings.threads, [&](int chunk) {
        double chunk_change2 = 0.0, chunk_size2 = 0.0;
        int failures = 0;
        sweep(ws.chunk_begin[chunk], ws.chunk_begin[chunk + 1], chunk_change2, chunk_size2,
              failures);
        ws.chunk_change2[chunk] = chunk_change2;
        ws.chunk_size2[chunk] = chunk_size2;
        ws.chunk_failures[chunk] = failures;
      });
      for (int chunk = 0; chunk < chunks; ++chunk) {
        change2 += ws.chunk_change2[chunk];
        size2 += ws.chunk_size2[chunk];
        stats.local_failures += ws.chunk_failures[chunk];
      }
    } else {
      sweep(0, n, change2, size2, stats.local_failures);
    }
    stats.iterations = it + 1;
    if (residualDue(settings, it, change2, size2)) {
      stats.residual = residualNow();
      if (momentum) momentum->watch(stats.residual);
      if (stats.residual < settings.tolerance) {
        stats.status = SolverStatus::Converged;
        return stats;
      }
    }
    if (momentum && it + 1 < settings.max_iterations) momentum->step(change2, v);
  }
  stats.residual = residualNow();
  stats.status =
      stats.residual < settings.tolerance ? SolverStatus::Converged : SolverStatus::MaxIterations;
  return stats;
}

}  // namespace sweep
