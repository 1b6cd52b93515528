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

const VectorX& forwardDynamicsWithAddedMass(const Model& model, Data& data, const VectorX& v,
                                            const VectorX& tau, const VectorX& added,
                                            const std::vector<char>& shifted) {
  computeMassBlocks(model, data, /*include_constant=*/false);
  factorizeMassMatrix(model, data);
  data.shifted_mass.resize(model.components.size());
  for (std::size_t c = 0; c < model.components.size(); ++c) {
    if (!shifted[c]) continue;
    const Component& comp = model.components[c];
    MatrixX& block = data.shifted_mass[c];
    block = data.mass_blocks[c];  // sized by the first step, then reused
    block.diagonal() += added.segment(comp.v_index, comp.nv);
    data.mass_factors[c].compute(block);
  }
  biasForcesFromKinematics(model, data, v);
  data.ddq = tau - data.tau;
  applyMassInverse(model, data, data.ddq, data.ddq);
  return data.ddq;
}

}  // namespace sweep
