#include "framework/energy.hpp"

#include "framework/crba.hpp"
#include "framework/error.hpp"
#include "framework/kinematics.hpp"
#include "framework/parallel.hpp"

namespace sweep {

double kineticEnergy(const Model& model, Data& data, const VectorX& q, const VectorX& v) {
  forwardKinematics(model, data, q, v);
  return kineticEnergy(model, static_cast<const Data&>(data));
}

double potentialEnergy(const Model& model, Data& data, const VectorX& q) {
  forwardKinematics(model, data, q);
  return potentialEnergy(model, static_cast<const Data&>(data));
}

Vector3 centerOfMass(const Model& model, Data& data, const VectorX& q) {
  forwardKinematics(model, data, q);
  double mass = 0.0;
  Vector3 moment = Vector3::Zero();
  for (size_t i = 0; i < model.bodies.size(); ++i) {
    const Inertia& inertia = model.bodies[i].inertia;
    mass += inertia.mass;
    moment += inertia.mass * data.world_pose[i].apply(inertia.com);
  }
  if (!(mass > 0.0)) throw InputError("centre of mass: the model has no mass");
  return moment / mass;
}

double kineticEnergy(const Model& model, const Data& data) {
  double energy =
      sumInChunks(static_cast<long>(model.bodies.size()), data.threads, [&](long i, double& sum) {
        sum += 0.5 * data.velocity[i].dot(model.bodies[i].inertia.apply(data.velocity[i]));
      });
  for (std::size_t c = 0; c < model.components.size(); ++c) {
    const Component& comp = model.components[c];
    if (comp.system < 0) continue;
    const VectorX v = data.v.segment(comp.v_index, comp.nv);
    energy += 0.5 * v.dot(systemMass(model, static_cast<int>(c), data.q) * v);
  }
  return energy;
}

double potentialEnergy(const Model& model, const Data& data) {
  double energy =
      sumInChunks(static_cast<long>(model.bodies.size()), data.threads, [&](long i, double& sum) {
        const Inertia& inertia = model.bodies[i].inertia;
        sum -= inertia.mass * model.gravity.dot(data.world_pose[i].apply(inertia.com));
      });
  for (const Component& comp : model.components)
    if (comp.system >= 0 && model.systems[comp.system].potential)
      energy += model.systems[comp.system].potential(data.q.segment(comp.q_index, comp.nq));
  return energy;
}

}  // namespace sweep
