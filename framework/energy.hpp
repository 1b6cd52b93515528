#pragma once
#include "framework/data.hpp"

namespace sweep {

// Energies at a state: they run the kinematics first, so that no earlier call's state leaks in.
double kineticEnergy(const Model& model, Data& data, const VectorX& q, const VectorX& v);
double potentialEnergy(const Model& model, Data& data, const VectorX& q);
// The centre of mass of every body at q (InputError for a massless model).
Vector3 centerOfMass(const Model& model, Data& data, const VectorX& q);

// The same on the kinematics data already holds: sum over bodies of 1/2 v_i . I_i v_i after
// forwardKinematics(q, v) (crba(q) alone leaves the velocities of an older call), and
// -sum_i m_i g . c_i after forwardKinematics.
double kineticEnergy(const Model& model, const Data& data);
double potentialEnergy(const Model& model, const Data& data);

}  // namespace sweep
