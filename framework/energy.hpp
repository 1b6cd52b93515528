#pragma once
#include "framework/data.hpp"

namespace sweep {

// Sum over bodies of 1/2 v_i . I_i v_i (after forwardKinematics with velocities).
double kineticEnergy(const Model& model, const Data& data);
// Gravitational potential -sum_i m_i g . c_i (after forwardKinematics).
double potentialEnergy(const Model& model, const Data& data);

}  // namespace sweep
