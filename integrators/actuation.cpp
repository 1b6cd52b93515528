#include "integrators/actuation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "framework/dynamics.hpp"
#include "integrators/step_data.hpp"

namespace sweep::stepping {

void actuatedFreeVelocity(const StepModel& m, StepData& d) {
  const Model& model = m.model;
  const double h = m.settings.h, t_m = d.t + 0.5 * h, t_end = d.t + h;
  d.added_mass.setZero();
  const int count = static_cast<int>(model.actuators.size());
  for (int a = 0; a < count; ++a) {
    const JointActuator& actuator = model.actuators[a];
    const ActuatorCommand& command = d.actuator_command[a];
    const int j = actuator.v_index;
    if (actuator.prescribed) {  // a row of the solve; its reaction is read after it
      d.actuator_explicit[a] = d.actuator_damping[a] = 0.0;
      d.actuator_saturated[a] = 0;
      d.actuator_target[a] = actuator.position.at(t_end);
      continue;
    }
    double torque = !std::isnan(command.torque) ? command.torque
                    : actuator.torque.empty()   ? 0.0
                                                : actuator.torque.at(t_m);
    double damping = 0.0;
    d.actuator_target[a] = std::numeric_limits<double>::quiet_NaN();
    if (actuator.servo()) {
      const bool commanded = !std::isnan(command.position);
      const double q_ref = commanded ? command.position : actuator.targetPosition(t_end);
      const double v_ref = !std::isnan(command.velocity) ? command.velocity
                           : commanded                   ? 0.0
                                                         : actuator.targetVelocity(t_end);
      if (commanded || !actuator.position.empty()) d.actuator_target[a] = q_ref;
      torque += actuator.kp * (q_ref - d.q[actuator.q_index]) + actuator.kd * v_ref;
      damping = actuator.kd + h * actuator.kp;
    }
    d.actuator_explicit[a] = torque;
    d.actuator_damping[a] = damping;
    d.actuator_saturated[a] = std::abs(torque) > actuator.max_torque && damping == 0.0;
    if (d.actuator_held[a] != 0) {  // held at its limit by holdActuatorLimits
      d.actuator_saturated[a] = 1;
      d.actuator_torque[a] = d.actuator_held[a] * actuator.max_torque;
      d.tau[j] += d.actuator_torque[a];
    } else if (damping == 0.0) {
      d.actuator_torque[a] = std::clamp(torque, -actuator.max_torque, actuator.max_torque);
      d.tau[j] += d.actuator_torque[a];
    } else {
      d.tau[j] += torque - damping * d.v[j];
      d.added_mass[j] += h * damping;
    }
  }
  // The torque limits on the contact-free velocity. tau = clamp(tau_e - c v, +-max)
  // with v a function of every servo's tau is a box-constrained program in the servos' torques
  // (min 1/2 r^T (C^-1 + h S^T M^-1 S) r - (C^-1 tau_e - S^T v_0)^T r, r in the box), solved
  // by its primal-dual active set (Hintermueller, Ito & Kunisch 2003): a servo is at its limit
  // while its implicit torque at the resulting velocity points past it, implicit otherwise;
  // each round one factorization of the actuated trees. One servo is exact in one round.
  for (int round = 0; round <= 2 * count + 2; ++round) {
    d.v_free = d.v + h * forwardDynamicsWithAddedMass(model, d.model_data, d.v, d.tau, d.added_mass,
                                                      d.actuated_component);
    bool changed = false;
    for (int a = 0; a < count; ++a) {
      const JointActuator& actuator = model.actuators[a];
      const double c = d.actuator_damping[a];
      if (c == 0.0) continue;
      const int j = actuator.v_index;
      const double implicit_torque = d.actuator_explicit[a] - c * d.v_free[j];
      const double explicit_part = d.actuator_explicit[a] - c * d.v[j];
      if (!d.actuator_saturated[a] && std::abs(implicit_torque) > actuator.max_torque) {
        d.actuator_saturated[a] = 1;
        d.actuator_torque[a] = std::copysign(actuator.max_torque, implicit_torque);
        d.tau[j] += d.actuator_torque[a] - explicit_part;
        d.added_mass[j] = 0.0;
        changed = true;
      } else if (d.actuator_saturated[a] && d.actuator_held[a] == 0 &&
                 !(implicit_torque * std::copysign(1.0, d.actuator_torque[a]) >
                   actuator.max_torque)) {
        d.actuator_saturated[a] = 0;
        d.tau[j] += explicit_part - d.actuator_torque[a];
        d.added_mass[j] = h * c;
        changed = true;
      }
    }
    if (!changed) break;
  }
}

bool holdActuatorLimits(const StepModel& m, StepData& d) {
  bool held = false;
  const Model& model = m.model;
  for (std::size_t a = 0; a < model.actuators.size(); ++a) {
    const double c = d.actuator_damping[a];
    if (c == 0.0 || d.actuator_saturated[a]) continue;
    const double torque = d.actuator_explicit[a] - c * d.v_free[model.actuators[a].v_index];
    if (std::abs(torque) <= model.actuators[a].max_torque) continue;
    d.actuator_held[a] = torque > 0.0 ? 1 : -1;
    held = true;
  }
  return held;
}

void actuatorTorques(const StepModel& m, StepData& d) {
  // motors and saturated servos applied what actuatedFreeVelocity set; a prescribed joint's
  // torque is its constraint's reaction
  const Model& model = m.model;
  for (std::size_t a = 0; a < model.actuators.size(); ++a) {
    if (model.actuators[a].prescribed) {
      d.actuator_torque[a] = d.constraint_impulse[model.actuators[a].constraint].x() / m.settings.h;
      continue;
    }
    const double c = d.actuator_damping[a];
    if (c != 0.0 && !d.actuator_saturated[a])
      d.actuator_torque[a] = d.actuator_explicit[a] - c * d.v_free[model.actuators[a].v_index];
  }
}

}  // namespace sweep::stepping
