#pragma once
// Primal-dual interior-point method for the programs of mprgp.hpp,
//
//   min_x  f(x) = 1/2 x^T A x + b^T x,   x_b in C_b,
//
// with C_b one of {0}, R, [0, inf), [-r, r] or the disc |x_b| <= r: every stage of scheme B,
// 2D and 3D. Written as a cone quadratic program (Vandenberghe 2010, "The CVXOPT linear and
// quadratic cone program solvers", the coneqp algorithm, without equality constraints):
//
//   min 1/2 x^T A x + b^T x   s.t.  G x + s = h,  s in K,
//
// K a product of half-lines (x >= 0: s = x; an interval: s = (r + x, r - x)) and
// three-dimensional second-order cones (a disc: s = (r, x_1, x_2), s_0 >= |(s_1, s_2)|). Each
// iteration is one Mehrotra predictor-corrector step (Mehrotra 1992, SIAM J. Optim. 2) in the
// Nesterov-Todd scaling W (Nesterov & Todd 1998, SIAM J. Optim. 8; for the cone, W =
// eta (2 v v^T - J), CVXOPT's formula): the Newton matrix
//
//   A + G^T W^-2 G
//
// is A plus a diagonal term on each bounded variable and a 2 x 2 block on each disc, so its
// pattern is A's for every iteration of a step: one symbolic analysis (the sparse Cholesky of
// projected_newton.hpp, split along the elimination tree on threads), then one numeric
// factorization and two solves per iteration. The number of iterations follows the
// complementarity's decrease, about 20 to 40, and does not grow with the size or depth of a
// pile, where MPRGP's and APGD's grow like sqrt(cond A) and the active-set Newton steps follow
// the faces that change. A 1e-9 regularization on the diagonal keeps the factorization of a
// singular A (redundant rows, free held rows) defined.
//
// Stop: mprgp.hpp's natural-map residual at x below the tolerance, measured at the end through
// the operator as the other solvers measure it. The solve is handed to MPRGP / APGD from the
// warm start where the factorization fails or the cap (min(max_iterations, 100)) is reached.
#include <vector>

#include "integrators/mprgp.hpp"
#include "integrators/projected_newton.hpp"

namespace sweep {

struct InteriorPointWorkspace {
  // half-line constraints: the variable, G's coefficient (-1: s = h + x, +1: s = h - x), h
  std::vector<int> lp_var;
  std::vector<double> lp_sign, lp_h;
  std::vector<double> lp_s, lp_z, lp_ds, lp_dz, lp_ds_affine, lp_dz_affine, lp_d;
  // second-order cones of discs: the first of the two variables, the radius; s, z, their
  // steps and the scaling (eta and v), three values per cone
  std::vector<int> soc_var;
  std::vector<double> soc_r;
  std::vector<double> soc_s, soc_z, soc_ds, soc_dz, soc_ds_affine, soc_dz_affine, soc_d;
  std::vector<double> soc_eta, soc_v;
  std::vector<int> soc_offdiagonal;  // the position of A's (j + 1, j) entry in its column j
  std::vector<char> fixed;           // variables held at 0
  std::vector<int> diagonal;         // the position of A's (j, j) entry
  std::vector<double> r_x, rhs, dx, x_trial, g;
};

// Whether solveInteriorPoint takes this program: every block fixed, free, a half-line (size
// 1), an interval or a disc.
bool interiorPointApplies(const SeparableSet& set);

// Same contract as solveMprgp: x in a warm start, out the solution; v in the velocity at x = 0,
// out at the solution. stats.iterations counts the interior-point iterations (each one
// factorization) plus a hand-over's.
MprgpStats solveInteriorPoint(const QpOperator& op, const SeparableSet& set,
                              const MprgpSettings& settings, std::vector<double>& x, VectorX& v,
                              ProjectedNewtonWorkspace& newton, InteriorPointWorkspace& ws,
                              MprgpWorkspace& fallback);

}  // namespace sweep
