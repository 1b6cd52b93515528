#pragma once
// Active-set Newton solver with a sparse Cholesky factorization, for the programs of mprgp.hpp
// whose sets are boxes (fixed, free, >= 0, intervals) and discs |x_b| <= r:
//
//   min_x  f(x) = 1/2 x^T A x + b^T x,   x_b in C_b,   A = J^T K = E^T H^T M^-1 H E,
//
// A formed explicitly from the operator's columns (QpOperator::columns), its pattern ordered
// (AMD; from 4096 rows, METIS's separator last and CAMD on its two sides) and analysed when it
// differs from the last solve's, then factorized by SuiteSparse
// CHOLMOD's simplicial LDL^T on a copy permuted once per pattern, so that no step allocates. Two
// kinds of step, each one numeric factorization of A reduced to the free variables (the others'
// rows and columns replaced by the identity, so every step refactors the same pattern), plus rho I
// on the free ones, rho = 1e-4 of the unit diagonal: a proximal term that keeps a singular A_FF
// (redundant rows) factorizable and bounds the step along directions of zero curvature. It costs a
// factor rho / lambda of the error per step along a direction of curvature lambda:
//   - a semismooth Newton step on the natural map F(x) = x - P(x - g(x)), g = A x + b: the
//     primal-dual active set step (Hintermueller, Ito & Kunisch 2003, "The primal-dual
//     active set strategy as a semismooth Newton method", SIAM J. Optim. 13). Each variable
//     is held at a bound where x - g leaves the box strictly (one on its bound with zero
//     gradient stays free: a pile at rest closes in one face, not one layer a step), the free
//     ones solve A_FF x_F = -b_F - A_FH x_H exactly, and the step towards that point is halved
//     until |F| falls (Armijo). Undamped, the number of steps follows the face changes, not the
//     conditioning of A, so it does not grow with the depth of a pile where CG's grows like
//     sqrt(cond A). Redundant rows with GLOBAL tangents leave faces whose program is
//     unbounded (a self-equilibrated set of impulses that does work on the tangents); there
//     the proximal term and the line search bound the step.
//     A disc (3D stage 5b) sticks where |x_b - g_b| <= r (both variables free) and slides
//     otherwise: x_b is put on the circle at n = (x_b - g_b) / |x_b - g_b| and moves along its
//     tangent tau only, the Newton matrix taken in the frame (n, tau) (R^T A R, R a 2 x 2
//     rotation per sliding disc: the same pattern) with the circle's curvature lambda / r added
//     on tau, lambda = max(0, -n . g_b) the multiplier that holds the disc on it. This is the
//     generalized Jacobian of the disc's projection, (r / |y|)(I - n n^T), |y| = r + lambda:
//     the primal-dual active set step for friction discs of Hueeber, Stadler & Wohlmuth 2008
//     ("A primal-dual active set algorithm for three-dimensional contact problems with Coulomb
//     friction", SIAM J. Sci. Comput. 30), here with the thresholds frozen;
//   - where no step length lowers |F|, a projected Newton step from the best point so far
//     (Bertsekas 1982, SIAM J. Control Optim. 20): Newton on the variables not binding within
//     eps = min(1e-3, |x - P(x - g)|), a gradient step on the binding ones (a disc binds whole),
//     a projected Armijo line search on f.
// The solve is handed to MPRGP / APGD (solveSeparableQp, from the caller's warm start, with the
// remaining iteration budget) when a factorization fails, the line search finds no descent (no
// solution: the dual falls without bound) or 200 factorizations did not converge. Stop: mprgp.hpp's
// natural-map residual, recomputed at the end through the operator. Each step costs a numeric
// factorization, whose fill grows faster than the rows in a 2D or 3D contact network: it pays where
// CG needs many iterations (deep piles, tight tolerances). On MprgpSettings::threads threads: the
// factorization split along the elimination tree (disjoint subtrees at once, then the rows above
// them) and so are the triangular solves, the products with A row by row, the vector loops by
// variables and their sums in fixed chunks; the same bits for every count.
#include <memory>
#include <utility>
#include <vector>

#include "integrators/mprgp.hpp"

namespace sweep {

class SparseCholesky;  // integrators/sparse_cholesky.hpp

struct ProjectedNewtonWorkspace {
  ProjectedNewtonWorkspace();
  ~ProjectedNewtonWorkspace();
  ProjectedNewtonWorkspace(ProjectedNewtonWorkspace&&) noexcept;
  ProjectedNewtonWorkspace& operator=(ProjectedNewtonWorkspace&&) noexcept;

  SparseColumns J, K;  // H E and M^-1 H E, one column per variable
  // J by velocity: the variables whose column has an entry at velocity k, and that entry
  std::vector<int> by_dof_begin, by_dof_variable;
  std::vector<double> by_dof_value;
  // A = J^T K, lower triangle, compressed columns with sorted rows; the factorized values
  std::vector<int> a_begin, a_row;
  std::vector<double> a_value, factor_value;
  // A whole, by rows, columns sorted: the products, row by row on threads
  std::vector<int> full_begin, full_column;
  std::vector<double> full_value;
  std::vector<double> sum_parts;  // the chunked sums' parts (framework/parallel.hpp)
  std::vector<ChunkSums> residual_parts;
  std::vector<double> accumulator;
  std::vector<int> marker, touched;
  std::vector<double> b, g, d, x_trial, g_trial;
  std::vector<char> binding, side;
  std::vector<double> lower, upper, x_start, x_best, x_prev, g_prev;
  // discs: each variable's partner in its two-variable block (-1 in a one-variable block); for
  // each entry (i, j) of A's lower triangle, the positions of the four entries
  // A(first_i + a, first_j + c) of its blocks' 2 x 2 coupling (-1 past a one-variable block)
  std::vector<int> partner, block_entry;
  // a sliding disc's frame: its unit normal n at its two variables (tau = (-n_1, n_0)), whether
  // the disc's variables are rotated into (n, tau), and the circle's curvature lambda / r at its
  // tangent variable
  std::vector<double> frame, curvature;
  std::vector<char> rotated;
  std::unique_ptr<SparseCholesky> cholesky;

  // the threads the last pattern's factorization is split over (1: CHOLMOD's own, unsplit)
  int factorThreads() const;
};

// A = J^T K from ws.J and ws.K (lower triangle in a_begin / a_row / a_value, the whole matrix by
// rows in full_*), for the direct solvers (this one and interior_point.hpp). The pattern holds
// every 2 x 2 coupling of two-variable blocks whole (structural zeros where the columns miss),
// so that a rotation of a disc's variables keeps it; ws.partner is set from the blocks.
void formDelassus(ProjectedNewtonWorkspace& ws, const SeparableSet& set, int velocities);
// y = A x + ws.b from the formed A, on threads, the same bits for every count
void delassusGradient(const ProjectedNewtonWorkspace& ws, const std::vector<double>& x,
                      std::vector<double>& y, int threads);

// A direct solver's answer x (a candidate when it met the tolerance in its own measure),
// checked as MPRGP checks one: the velocity v0 + M^-1 H E x and the natural-map residual
// through the operator (g: scratch), into stats (2 products). Returns whether it meets the
// tolerance; only then does v take that velocity.
bool acceptDirectAnswer(const QpOperator& op, const SeparableSet& set,
                        const MprgpSettings& settings, const std::vector<double>& x, bool candidate,
                        VectorX& v, std::vector<double>& g, MprgpWorkspace& fallback,
                        MprgpStats& stats);

// Whether solveProjectedNewton takes this program: every block a box or a disc.
bool projectedNewtonApplies(const SeparableSet& set);

// Same contract as solveMprgp: x in a warm start, out the solution; v in the velocity at
// x = 0, out at the solution. stats.iterations counts factorized steps (stats.newton_steps)
// plus the MPRGP hand-over's iterations.
MprgpStats solveProjectedNewton(const QpOperator& op, const SeparableSet& set,
                                const MprgpSettings& settings, std::vector<double>& x, VectorX& v,
                                ProjectedNewtonWorkspace& ws, MprgpWorkspace& fallback);

}  // namespace sweep
