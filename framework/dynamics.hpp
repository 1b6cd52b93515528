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

}  // namespace sweep
