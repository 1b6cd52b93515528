#pragma once
// Scheme B's two stages solved as the convex quadratic programs they are: by MPRGP / APGD
// (integrators/mprgp.hpp) on the matrix-free Delassus operator, or by active-set Newton steps
// on its assembled form (integrators/projected_newton.hpp; solver newton, or auto in 2D). Same
// inputs, outputs and meaning as solveNormalStage and solveFrictionStage
// (integrators/stage_solvers.hpp), which call these when the stage's solver is not nlgs.
//
// Stage 5a, the dual of min 1/2 |v - v_free|_M^2 subject to W_N^T v + bias >= 0 on the index
// set, in the scaled normals Lambda_c = s_c lambda_c (s_c^2 = W_NN,c, unit diagonal):
//   min 1/2 Lambda^T D Lambda + xi_0^T Lambda,  Lambda >= 0,
//   D = S^-1 W_N^T M^-1 W_N S^-1,  xi_0 = S^-1 (W_N^T v_free + known + bias).
//
// Stage 5b with thresholds S_c = mu_c lambda_N,c frozen (reference 4.3; docs/schemes.md), per
// contact the variables
//   delta_c   normal correction: free on a held row (GLOBAL, lambda_N > 0), >= 0 on a guarded
//             one (OpenContacts::Unilateral), absent otherwise;
//   lambda_T  tangential impulse in the disc |lambda_T| <= S_c (2D: an interval), or the
//             METRIC bound's ellipse mapped to a disc;
//   R_c       rolling torque impulse, |R_c| <= mu_r R* lambda_N,c;
// minimizing 1/2 x^T W x + x^T (H^T v1 + known - target), target = (held normal velocity or
// -bias, the tangential velocity of v_N, 0): the KKT system whose block Gauss-Seidel is
// solveFrictionStage's sweep. v_N, the M-projection of v1 on the closed normals, is the
// solution of a consistent (possibly singular) linear system, solved by conjugate gradients:
// MPRGP with every block free.
#include <vector>

#include "integrators/contact_problem.hpp"
#include "integrators/friction_stage.hpp"
#include "integrators/solver_settings.hpp"
#include "integrators/solver_workspace.hpp"

namespace sweep {

SolverStats solveNormalStageConvex(const ContactProblem& problem, const SolverSettings& settings,
                                   std::vector<double>& lambda_N, VectorX& v,
                                   SolverWorkspace& workspace);

SolverStats solveFrictionStageConvex(const ContactProblem& problem, const SolverSettings& settings,
                                     const FrictionStageOptions& options,
                                     const std::vector<double>& lambda_N,
                                     std::vector<double>& delta, std::vector<Vector2>& lambda_T,
                                     VectorX& v, SolverWorkspace& workspace,
                                     std::vector<Vector2>* rolling = nullptr,
                                     const std::vector<double>* threshold_impulse = nullptr);

// v_N = M^-1 N_A y with (N_A^T M^-1 N_A) y = N_A^T v1, stage 5b's projection of v1 on the
// closed normals, for both of its solvers: conjugate gradients (MPRGP with every block free,
// which converges in about sqrt(cond) products where Gauss-Seidel needs about cond sweeps);
// then each row's offset W_T^T v_N in workspace.offset. Returns the row visits it took.
long projectOnClosedNormalsByCg(const ContactProblem& problem, const SolverSettings& settings,
                                const FrictionRowRule& rule, const VectorX& v1,
                                SolverWorkspace& workspace);

}  // namespace sweep
