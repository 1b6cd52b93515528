#pragma once
// Joint actuators (framework/actuator.hpp) in the step of either scheme. Over the step from
// (q_k, v_k), a servo's torque is that of its spring at the backward-Euler position
// q_k + h v_{k+1} and of its damper at v_{k+1}:
//
//   tau = motor(t_m) + kp (q_ref(t_{k+1}) - q_k - h v_{k+1}) + kd (v_ref(t_{k+1}) - v_{k+1})
//       = tau_e - c v_{k+1},   tau_e = motor + kp (q_ref - q_k) + kd v_ref,   c = kd + h kp,
//
// which enters the step's momentum balance M (v_{k+1} - v_k) = h (f - b) + h tau + H P as
//
//   (M + h C) v_{k+1} = M v_k + h (f - b + tau_e) + H P,   C = diag(c):
//
// M + h C replaces M in the contact-free velocity and in every M^-1 of the contact solve
// (Data::mass_factors). This is MuJoCo's implicit damping with the spring made implicit too,
// the iteration matrix of Siconos' MoreauJeanOSI at theta = 1 for a linear spring-damper: a
// servo is stable at any gain and step, its stiff modes damped (by 1/sqrt(2) a step in the
// limit kp h^2 >> M), where a midpoint spring (theta = 1/2) would ring undamped.
// Torque limits, |tau| <= max_torque, in two places:
//   - on the contact-free velocity: tau = clamp(tau_e - c v, +-max) with v depending on every
//     servo's tau is a box-constrained program in the torques, solved by its primal-dual active
//     set (actuatedFreeVelocity's rounds): a servo at its limit applies +-max_torque as a motor;
//   - after the contact solve: a servo whose implicit torque at v_{k+1} is past its limit
//     (contacts pushed on it) is held at it and the step's solve is done again
//     (holdActuatorLimits, TimeStepper::step).
// A prescribed joint is no force here: its motion is a rheonomic bilateral constraint of the
// solve (ConstraintFunction::drive, integrators/contact_assembly.cpp), and its torque the
// constraint's impulse over h.
#include <limits>
#include <vector>

namespace sweep {

struct StepModel;
struct StepData;

// What Python sets between steps (TimeStepper::command); NaN: the actuator's own table.
// A commanded position without a commanded velocity aims at rest (v_ref = 0). A prescribed
// joint commanded a position P (and a velocity V, else 0) moves as q(t) = P + V (t - time) from
// the step after the command, `time` the command's.
struct ActuatorCommand {
  double torque = std::numeric_limits<double>::quiet_NaN();
  double position = std::numeric_limits<double>::quiet_NaN();
  double velocity = std::numeric_limits<double>::quiet_NaN();
  double time = 0.0;  // set by TimeStepper::command
};

namespace stepping {
// 4 with actuators: d.v_free from (M + h C), the torques' explicit parts in d.tau
void actuatedFreeVelocity(const StepModel& m, StepData& d);
// after 5: servos whose torque at v_{k+1} is past their limit are held at it for the step
// (d.actuator_held); returns whether any was, so that the step is solved again
bool holdActuatorLimits(const StepModel& m, StepData& d);
// after 5: the torque each actuator applied over the step (d.actuator_torque)
void actuatorTorques(const StepModel& m, StepData& d);
}  // namespace stepping

}  // namespace sweep
