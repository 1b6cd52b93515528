#include "framework/dynamics.hpp"

#include "framework/crba.hpp"
#include "framework/rnea.hpp"

namespace sweep {

const VectorX& forwardDynamics(const Model& model, Data& data, const VectorX& q, const VectorX& v,
                               const VectorX& tau) {
  crba(model, data, q);
  factorizeMassMatrix(model, data);
  biasForces(model, data, q, v);
  data.ddq = tau - data.tau;
  applyMassInverse(model, data, data.ddq, data.ddq);
  return data.ddq;
}

}  // namespace sweep
