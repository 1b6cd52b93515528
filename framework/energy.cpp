#include "framework/energy.hpp"

#include "framework/error.hpp"
#include "framework/kinematics.hpp"

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
  double energy = 0.0;
  for (size_t i = 0; i < model.bodies.size(); ++i)
    energy += 0.5 * data.velocity[i].dot(model.bodies[i].inertia.apply(data.velocity[i]));
  return energy;
}

double potentialEnergy(const Model& model, const Data& data) {
  double energy = 0.0;
  for (size_t i = 0; i < model.bodies.size(); ++i) {
    const Inertia& inertia = model.bodies[i].inertia;
    energy -= inertia.mass * model.gravity.dot(data.world_pose[i].apply(inertia.com));
  }
  return energy;
}

}  // namespace sweep
