#include "framework/dynamics.hpp"

#include "framework/crba.hpp"
#include "framework/kinematics.hpp"
#include "framework/rnea.hpp"

namespace sweep {

const VectorX& forwardDynamics(const Model& model, Data& data, const VectorX& q, const VectorX& v,
                               const VectorX& tau) {
  forwardKinematics(model, data, q, v);
  return forwardDynamicsFromKinematics(model, data, v, tau);
}

const VectorX& forwardDynamicsFromKinematics(const Model& model, Data& data, const VectorX& v,
                                             const VectorX& tau) {
  // constant blocks (free particles) are skipped; the others are rebuilt and factored
  computeMassBlocks(model, data, /*include_constant=*/false);
  factorizeMassMatrix(model, data);
  biasForcesFromKinematics(model, data, v);
  data.ddq = tau - data.tau;
  applyMassInverse(model, data, data.ddq, data.ddq);
  return data.ddq;
}

}  // namespace sweep
