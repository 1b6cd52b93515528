#pragma once
// Nonlinear Gauss-Seidel solvers on a ContactProblem, matrix-free: v is kept current and each
// local update adds M^-1 H_c dP_c (reference sections 2.4-2.5; Jean 1999, "The non-smooth
// contact dynamics method", CMAME 177; Moreau 1999, CMAME 177).
//
// - solveCoulombNlgs (coulomb_sweeps.cpp): scheme A's coupled Newton-Coulomb problem, exact
//   local solves: P_c <- proj_C(mu_c)(P_c - W_cc^-1 U*_c) solved exactly per contact.
// - solveNormalStageNlgs (normal_stage.cpp): scheme B stage 5a, frictionless shock law on
//   M^-1-normalized normals, closed-form local update Lambda <- [Lambda - xi]_+.
// - solveFrictionStageNlgs (friction_stage.cpp): scheme B stage 5b, friction with thresholds
//   frozen from 5a.
// Each local update is one law of integrators/contact_laws.hpp applied to one row of
// integrators/rows.hpp; the sweeps (order, colours, NNCG, islands) are integrators/sweeps.hpp.
//
// Solvers never print and never allocate inside their sweeps (workspaces are sized by
// prepare(), between steps). Each returns a status and its statistics.
#include <vector>

#include "integrators/contact_problem.hpp"
#include "integrators/friction_stage.hpp"
#include "integrators/solver_settings.hpp"
#include "integrators/solver_workspace.hpp"

namespace sweep {

// v: in v_free, out the velocity after the impulses. P: in the warm start, out the impulses.
// rolling (problems with rolling rows): in the warm start, out the rolling torque impulses,
// bounded by rolling_bound times P_N and solved in the same sweeps.
// velocity_holds_warm_start: v is already v_free + M^-1 H P (a solve resumed with the same
// rows, integrators/distributed_stepper.hpp), and the warm start is not applied again.
SolverStats solveCoulombNlgs(const ContactProblem& problem, const SolverSettings& settings,
                             std::vector<Vector3>& P, VectorX& v, SolverWorkspace& workspace,
                             std::vector<Vector2>* rolling = nullptr,
                             bool velocity_holds_warm_start = false);

// For solvers that drive the sweeps themselves (integrators/distributed_stepper.hpp), on
// scheme A's rows rows[0, count) in that order, with no warm start: one Gauss-Seidel sweep
// (adds to the sums of the impulses' change and size, and to the local failures), and the sums
// of the relative natural-map residual that solveCoulombNlgs tests.
void sweepCoulombRows(const ContactProblem& problem, const SolverSettings& settings,
                      std::vector<Vector3>& P, std::vector<Vector2>* rolling, VectorX& v,
                      const int* rows, int count, double& change2, double& size2, int& failures);
void coulombResidualSums(const ContactProblem& problem, const std::vector<Vector3>& P,
                         const std::vector<Vector2>* rolling, const VectorX& v, const int* rows,
                         int count, double& f2, double& scale2);

// Stage 5a by NLGS; arguments as solveNormalStage's (integrators/stage_solvers.hpp).
SolverStats solveNormalStageNlgs(const ContactProblem& problem, const SolverSettings& settings,
                                 std::vector<double>& lambda_N, VectorX& v,
                                 SolverWorkspace& workspace);

// Stage 5b by NLGS; arguments as solveFrictionStage's (integrators/stage_solvers.hpp).
SolverStats solveFrictionStageNlgs(const ContactProblem& problem, const SolverSettings& settings,
                                   const FrictionStageOptions& options,
                                   const std::vector<double>& lambda_N, std::vector<double>& delta,
                                   std::vector<Vector2>& lambda_T, VectorX& v,
                                   SolverWorkspace& workspace,
                                   std::vector<Vector2>* rolling = nullptr,
                                   const std::vector<double>* threshold_impulse = nullptr);

}  // namespace sweep
