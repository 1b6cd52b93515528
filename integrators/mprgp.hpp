#pragma once
// MPRGP / MPGP: minimization of a convex quadratic over a product of simple convex sets,
//
//   min_x  f(x) = 1/2 x^T A x + b^T x,   x_b in C_b for every block b,
//
// C_b one of {0}, R, [0, inf), [-r, r] or the disc |x_b| <= r in R^2. A = E^T H^T M^-1 H E is
// a (scaled) Delassus operator, positive semidefinite (singular when rows are redundant) and
// never formed: the QpOperator maps impulses to velocities and velocities to gradients.
//
// Algorithm: modified proportioning with reduced gradient projections, MPRGP (Dostal &
// Schoberl 2005, "Minimizing quadratic functions subject to bound constraints with the rate of
// convergence and finite termination", Comput. Optim. Appl. 30), extended to separable convex
// sets as MPGP (Dostal & Kozubek 2012, Math. Program. 135). With the gradient g = A x + b split
// into the free gradient phi (blocks inside their set) and the chopped gradient beta (blocks on
// their boundary: the part of g that moves them inwards or along the boundary):
//   - proportional iterate (|beta|^2 <= Gamma^2 |phi|^2): conjugate gradient step on the free
//     blocks; when the step would leave the set, an expansion step instead: the largest
//     feasible step, then a projected free-gradient step of length alpha_bar;
//   - otherwise a proportioning step: exact line search along -beta, projected.
// Expansion and proportioning steps are checked for descent (the change of f from one more
// product); a step that would raise f is halved, an expansion's alpha_bar with it. alpha_bar
// starts at 1.9 over the largest Rayleigh quotient p^T A p / p^T p seen in the solve (1 for a
// unit diagonal). A direction of numerically zero curvature gets no CG step; met with a
// gradient along it, it means no solution exists, and the solve is reported unconverged.
// CG converges in about sqrt(cond A) iterations where Gauss-Seidel needs about cond A sweeps, and
// on a consistent singular system (redundant rows) it converges in the range of A without
// stalling.
//
// Stop: the natural-map residual F_b = x_b - P_b(x_b - g_b), relative to
// sqrt(sum_b max(|x_b|^2, |g_b|^2) + scale2_b), below the tolerance: in variables scaled to a
// unit diagonal this is Gauss-Seidel's residual (docs/schemes.md, "Convex stage solvers").
// No allocation in the iterations: the workspace is sized by the caller's first call per solve.
// Threads: every loop over variables, blocks or velocities splits from kParallelItems items on
// (framework/parallel.hpp); its sums are taken in fixed chunks, so that every thread count gives
// the same bits, and those of a plain loop up to kReduceChunk items.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "framework/data.hpp"

namespace sweep {

enum class BlockSet : std::uint8_t {
  Fixed,        // x_b = 0
  Free,         // x_b in R (a held, bilateral row)
  NonNegative,  // x_b >= 0 (a unilateral row)
  Ball,         // |x_b| <= radius: an interval (size 1) or a disc (size 2)
};

struct SeparableSet {
  std::vector<int> first;  // block b: variables [first[b], first[b] + size[b])
  std::vector<std::uint8_t> size;
  std::vector<BlockSet> set;
  std::vector<double> radius;  // Ball only
  std::vector<double> scale2;  // added to the block's residual scale (squared)
  int variables = 0;

  void clear();
  int add(BlockSet set, int size, double radius = 0.0, double scale2 = 0.0);  // first variable
  int blocks() const { return static_cast<int>(set.size()); }
};

// A ball of radius 0 is the point {0}: Fixed. Inline, with projectBlock: the solvers call them
// per block in every iteration.
inline BlockSet effectiveSet(const SeparableSet& s, int b) {
  return s.set[b] == BlockSet::Ball && !(s.radius[b] > 0.0) ? BlockSet::Fixed : s.set[b];
}
inline void projectBlock(const SeparableSet& s, int b, double* x) {
  const int n = s.size[b];
  switch (effectiveSet(s, b)) {
    case BlockSet::Fixed:
      for (int i = 0; i < n; ++i) x[i] = 0.0;
      return;
    case BlockSet::Free:
      return;
    case BlockSet::NonNegative:
      x[0] = std::max(x[0], 0.0);
      return;
    case BlockSet::Ball: {
      const double r = s.radius[b];
      if (n == 1) {
        x[0] = std::clamp(x[0], -r, r);
        return;
      }
      const double norm2 = x[0] * x[0] + x[1] * x[1];
      if (norm2 > r * r) {
        const double shrink = r / std::sqrt(norm2);
        x[0] *= shrink;
        x[1] *= shrink;
      }
      return;
    }
  }
}

// the Euclidean projection of every block
void project(const SeparableSet& set, std::vector<double>& x, int threads = 1);

// up to four sums taken together over fixed chunks (framework/parallel.hpp, reduceInChunks)
using ChunkSums = std::array<double, 4>;

// Sparse columns (compressed sparse column form), the variables' images over the velocities.
struct SparseColumns {
  std::vector<int> begin{0};  // column j: entries [begin[j], begin[j + 1])
  std::vector<int> row;
  std::vector<double> value;
  void clear() {
    begin.assign(1, 0);
    row.clear();
    value.clear();
  }
  void push(int r, double x) {
    row.push_back(r);
    value.push_back(x);
  }
  void endColumn() { begin.push_back(static_cast<int>(row.size())); }
  int columns() const { return static_cast<int>(begin.size()) - 1; }
};

// A = E^T H^T M^-1 H E, b = E^T (H^T v0 + known) - target, matrix-free.
class QpOperator {
 public:
  virtual ~QpOperator() = default;
  // z = M^-1 H E x (z overwritten, sized to the velocities)
  virtual void toVelocity(const std::vector<double>& x, VectorX& z) const = 0;
  // y = E^T (H^T v + known) - target (affine), or E^T H^T v (linear)
  virtual void toGradient(const VectorX& v, bool affine, std::vector<double>& y) const = 0;
  // the velocities M^-1 H E reaches (null: all of them): the solvers' vector operations on
  // velocities run over these only, where a powder bed's few hundred contacts would otherwise
  // pay for its 21 000 velocities at every iteration
  virtual const std::vector<int>* dofs() const { return nullptr; }
  // The columns of H E (J) and of M^-1 H E (K) over the velocities, one per variable, so that
  // A = J^T K can be formed for a direct solver; false when the operator cannot give them.
  virtual bool columns(SparseColumns& /*J*/, SparseColumns& /*K*/) const { return false; }
};

// z = 0 over dofs (all of z when null)
void clearVelocities(const std::vector<int>* dofs, VectorX& z, int threads = 1);

struct MprgpSettings {
  int max_iterations = 1500;
  double tolerance = 1e-6;
  double gamma = 1.0;  // proportioning constant Gamma
  int threads = 1;     // for the products and factorizations that split without changing bits
};

struct MprgpStats {
  int iterations = 0;
  int products = 0;  // operator products (toVelocity + toGradient pairs)
  int cg_steps = 0, expansions = 0, proportionings = 0;
  int newton_steps = 0;  // projected_newton.hpp: factorized steps before any MPRGP hand-over
  double residual = 0.0;
  bool converged = false;
  bool inconsistent = false;  // unbounded along a null direction of A: no solution exists
};

struct MprgpWorkspace {
  std::vector<double> g, p, Ap, phi, beta, x_half, g_half, x_trial, g_trial;
  VectorX z, z_trial;
  std::vector<ChunkSums> sums;  // the chunked sums' parts
  void prepare(int variables, int velocities);
};

// x: in a warm start (projected onto the set), out the solution. v: in the velocity at x = 0,
// out the velocity at the solution, v0 + M^-1 H E x.
MprgpStats solveMprgp(const QpOperator& op, const SeparableSet& set, const MprgpSettings& settings,
                      std::vector<double>& x, VectorX& v, MprgpWorkspace& ws);

// The same program by accelerated projected gradients, APGD (Nesterov's method as FISTA, Beck &
// Teboulle 2009; the contact solver of Mazhar, Heyn, Negrut & Tasora 2015, Chrono's
// ChSolverAPGD): one product per iteration, the step 1/L with L raised by backtracking and
// lowered by 10 % per iteration, and the momentum restarted when it points uphill (O'Donoghue &
// Candes 2015). Its rate does not depend on the shape of the sets, where MPGP's proportioning
// steps creep along the boundary of discs.
MprgpStats solveApgd(const QpOperator& op, const SeparableSet& set, const MprgpSettings& settings,
                     std::vector<double>& x, VectorX& v, MprgpWorkspace& ws);

// MPRGP when every set is a box (finite termination), APGD when a block is a disc.
MprgpStats solveSeparableQp(const QpOperator& op, const SeparableSet& set,
                            const MprgpSettings& settings, std::vector<double>& x, VectorX& v,
                            MprgpWorkspace& ws);

// The natural-map residual above at (x, g); on threads, its sums' parts kept in `parts`.
double naturalResidual(const SeparableSet& set, const std::vector<double>& x,
                       const std::vector<double>& g);
double naturalResidual(const SeparableSet& set, const std::vector<double>& x,
                       const std::vector<double>& g, int threads, std::vector<ChunkSums>& parts);
// Block b's terms of it: |x_b - P_b(x_b - g_b)|^2 added to f2, its scale to scale2 (nothing
// for a fixed block); the residual is sqrt(f2 / scale2), or sqrt(f2) where scale2 is 0.
void addResidualTerms(const SeparableSet& set, int b, const std::vector<double>& x,
                      const std::vector<double>& g, double& f2, double& scale2);

}  // namespace sweep
