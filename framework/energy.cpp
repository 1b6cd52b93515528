#include "framework/energy.hpp"

namespace sweep {

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
