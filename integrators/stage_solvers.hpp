#pragma once
// Scheme B's two stages (reference 4.3; Charles, Casenave & Glocker 2018, CMAME 334), each by
// the solver its settings name (SolverSettings::solver): NLGS (integrators/nlgs.hpp) or the
// stage as a convex program (integrators/convex_stages.hpp: MPRGP, APGD, active-set Newton).
//
//   5a  0 <= nhat^T v1 + e-term (+ gap term) _|_ Lambda >= 0   (frictionless shock)
//   5b  |lambda_T| <= S_c = mu_c lambda_N,c, maximal dissipation on the tangential part of
//       the motion; GLOBAL holds the closed normals' velocities (integrators/friction_stage.hpp)
#include <vector>

#include "integrators/friction_stage.hpp"
#include "integrators/solver_settings.hpp"
#include "integrators/solver_workspace.hpp"

namespace sweep {

// Stage 5a. lambda_N: in the warm start, out the physical normal impulses. v: in v_free, out
// v1.
SolverStats solveNormalStage(const ContactProblem& problem, const SolverSettings& settings,
                             std::vector<double>& lambda_N, VectorX& v, SolverWorkspace& workspace);

// Stage 5b. rolling: as for solveCoulombNlgs, the bound taken from the stage-5a lambda_N.
// lambda_N: the normal impulses of stage 5a (thresholds mu lambda_N). delta: in the
// warm start, out the normal corrections of GLOBAL mode (zero otherwise): bilateral on the
// contacts with lambda_N > 0, >= 0 on the others (OpenContacts::Unilateral).
// lambda_T: in the warm start, out the tangential impulses. v: in v1 (after 5a), out v2.
// The impulse on the rows H of contact c is then
//   (lambda_N + delta + tangentNormalPart(...), lambda_T).
// threshold_impulse: the normal impulse each threshold is taken from, S_c = mu_c times it
// (null: lambda_N; rolling bounds always take lambda_N).
SolverStats solveFrictionStage(const ContactProblem& problem, const SolverSettings& settings,
                               const FrictionStageOptions& options,
                               const std::vector<double>& lambda_N, std::vector<double>& delta,
                               std::vector<Vector2>& lambda_T, VectorX& v,
                               SolverWorkspace& workspace, std::vector<Vector2>* rolling = nullptr,
                               const std::vector<double>* threshold_impulse = nullptr);

}  // namespace sweep
