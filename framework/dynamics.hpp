#pragma once
#include "framework/data.hpp"

namespace sweep {

// data.ddq = M(q)^-1 (tau - b(q, v)): CRBA, Cholesky per component, RNEA for the bias.
const VectorX& forwardDynamics(const Model& model, Data& data, const VectorX& q, const VectorX& v,
                               const VectorX& tau);

}  // namespace sweep
