#pragma once
#include "framework/data.hpp"

namespace sweep {

// data.ddq = M(q)^-1 (tau - b(q, v)): CRBA, Cholesky per component, RNEA for the bias.
const VectorX& forwardDynamics(const Model& model, Data& data, const VectorX& q, const VectorX& v,
                               const VectorX& tau);
// The same on the kinematics data already holds (forwardKinematics(q, v) just called, as a
// time step does for its contact detection): the kinematics are not computed again.
const VectorX& forwardDynamicsFromKinematics(const Model& model, Data& data, const VectorX& v,
                                             const VectorX& tau);

// The same with a diagonal added to M on some velocities (`added`, nv entries, zero where
// none): data.ddq = (M + diag(added))^-1 (tau - b), an implicit damper's h c
// (integrators/actuation.hpp). data.mass_blocks keep M, which the energies read;
// data.mass_factors hold the factors of M + diag(added), which every later M^-1 of the step
// (the contact rows) applies. `shifted` marks the components refactored every call whatever
// their added entries: those that hold an actuated joint, constant mass blocks included.
const VectorX& forwardDynamicsWithAddedMass(const Model& model, Data& data, const VectorX& v,
                                            const VectorX& tau, const VectorX& added,
                                            const std::vector<char>& shifted);

}  // namespace sweep
