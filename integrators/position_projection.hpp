#pragma once
// Position projection after a step (scheme.projection), for either scheme: the direct
// projection of Siconos' MoreauJeanDirectProjectionOSI (Acary 2013, "Projected event-capturing
// time-stepping schemes for nonsmooth mechanical systems with unilateral contact and Coulomb's
// friction", CMAME 256, 224-250). At q_{k+1}, with v_{k+1} left as the step made it,
//
//   min_dq  1/2 dq^T M(q) dq   s.t.  g_c(q) + W_N,c(q)^T dq >= -tol/2   (contacts, limits),
//                                    g_c(q) + W_N,c(q)^T dq  = 0        (constraints),
//
// whose dual is the frictionless normal problem 0 <= g + W_N^T M^-1 W_N lambda _|_ lambda >= 0:
// stage 5a's program on a zero velocity with the gaps as its bias (a POS row with tau = 1),
// solved by the scheme's solver (Jean-Moreau: Gauss-Seidel sweeps with scheme.coulomb's
// settings; the staggered scheme: scheme.normal_stage's) to a relative residual of 1e-3. Then
// q <- q (+) M^-1 W_N lambda, and again from a new detection while the deepest overlap exceeds
// tol, up to max_rounds. Candidates farther than twice the deepest overlap stay out of a round.
// Overlaps go back to tol/2, not to zero, so that the contacts stay closed for VEL. Contacts
// with restitution, and those separating out of their overlap within a step, are held
// (W_N^T dq >= 0): lifting them would hand a rebound the overlap's potential energy.
// The velocities are not touched, so no energy enters them: what VEL keeps of an inelastic
// impact (about h times the landing speed) is pushed out at the step's end, where POS turns it
// into a separation speed. Driven bodies do not move; a prescribed joint's constraint is held
// at its commanded position.
#include "integrators/step_data.hpp"

namespace sweep::stepping {

// scheme.projection: after update (6) and before the diagnostics. Adds its rounds and its
// solver's iterations to d.stats (projection_rounds, projection_iterations).
void projectPositions(const StepModel& m, StepData& d);

}  // namespace sweep::stepping
