#pragma once
// Actuators on 1-dof joints (revolute, continuous, prismatic): a motor's torque (force on a
// prismatic joint) and a PD servo towards a target position and velocity, with a torque limit,
//
//   tau = motor(t) + kp (q_ref(t) - q) + kd (v_ref(t) - v),   |tau| <= max_torque,
//
// the data a model carries; integrators/actuation.hpp applies them in the step of either
// scheme, the servo's spring and damper implicitly.
#include <limits>
#include <string>
#include <vector>

namespace sweep {

struct Model;

// A function of time through (times, values), linear between them and constant outside; one
// value is a constant, none is "not given".
struct TimeTable {
  std::vector<double> times, values;

  static TimeTable constant(double value) { return {{0.0}, {value}}; }
  bool empty() const { return values.empty(); }
  double at(double t) const;
  double rate(double t) const;  // the slope of the segment holding t (0 outside, and for one value)
};

struct JointActuator {
  std::string joint;  // the joint's name in the model
  int body = 0, q_index = 0, v_index = 0;
  TimeTable torque;    // motor; empty: none
  double kp = 0.0;     // N m / rad (N / m)
  double kd = 0.0;     // N m s / rad (N s / m)
  TimeTable position;  // q_ref; empty: none (then kp is 0)
  TimeTable velocity;  // v_ref; empty: the rate of `position` (0 without one)
  double max_torque = std::numeric_limits<double>::infinity();
  // prescribed motion: the joint follows `position` exactly, as a rheonomic bilateral
  // constraint of both schemes' solves (Model::constraints[constraint]), its reaction the
  // actuator's torque (not bounded by max_torque); no motor, no servo
  bool prescribed = false;
  int constraint = -1;

  bool servo() const { return kp > 0.0 || kd > 0.0; }
  double targetPosition(double t) const { return position.empty() ? 0.0 : position.at(t); }
  double targetVelocity(double t) const {
    return !velocity.empty() ? velocity.at(t) : position.empty() ? 0.0 : position.rate(t);
  }
};

// Binds `actuator` to its joint by name and adds it to model.actuators (a prescribed one with its
// constraint to model.constraints); InputError starting with `where` when the joint is absent,
// not a 1-dof joint or already actuated, a gain is negative or not finite, kp has no position
// target, a table is not strictly increasing in time or holds a value that is not finite,
// max_torque is not positive, or a prescribed motion has no position or also a motor or servo.
void addJointActuator(Model& model, JointActuator actuator, const std::string& where);
// The same checks on a table alone ("<where>: ...")
void checkTimeTable(const TimeTable& table, const std::string& where);

}  // namespace sweep
