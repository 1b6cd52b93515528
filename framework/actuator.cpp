#include "framework/actuator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "framework/error.hpp"
#include "framework/model.hpp"

namespace sweep {

namespace {

// the segment [k, k + 1] holding t, for t inside the table's span
std::size_t segmentOf(const TimeTable& table, double t) {
  const auto it = std::upper_bound(table.times.begin(), table.times.end(), t);
  return static_cast<std::size_t>(it - table.times.begin()) - 1;
}

std::string number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", value);
  return text;
}

}  // namespace

double TimeTable::at(double t) const {
  if (values.size() == 1 || t <= times.front()) return values.front();
  if (t >= times.back()) return values.back();
  const std::size_t k = segmentOf(*this, t);
  const double s = (t - times[k]) / (times[k + 1] - times[k]);
  return values[k] + s * (values[k + 1] - values[k]);
}

double TimeTable::rate(double t) const {
  if (values.size() < 2 || t < times.front() || t >= times.back()) return 0.0;
  const std::size_t k = segmentOf(*this, t);
  return (values[k + 1] - values[k]) / (times[k + 1] - times[k]);
}

void checkTimeTable(const TimeTable& table, const std::string& where) {
  if (table.times.size() != table.values.size())
    throw InputError(where + ": " + std::to_string(table.times.size()) + " times for " +
                     std::to_string(table.values.size()) + " values");
  for (std::size_t k = 0; k < table.values.size(); ++k) {
    if (!std::isfinite(table.times[k]))
      throw InputError(where + ".times[" + std::to_string(k) + "] = " + number(table.times[k]) +
                       " must be finite");
    if (!std::isfinite(table.values[k]))
      throw InputError(where + ".values[" + std::to_string(k) + "] = " + number(table.values[k]) +
                       " must be finite");
    if (k > 0 && !(table.times[k] > table.times[k - 1]))
      throw InputError(where + ".times[" + std::to_string(k) + "] = " + number(table.times[k]) +
                       " must be greater than the time before it, " + number(table.times[k - 1]));
  }
}

void addJointActuator(Model& model, JointActuator actuator, const std::string& where) {
  int body = -1;
  for (std::size_t i = 0; i < model.bodies.size(); ++i)
    if (model.bodies[i].joint_name == actuator.joint) body = static_cast<int>(i);
  if (body < 0) throw InputError(where + ": the model has no joint named '" + actuator.joint + "'");
  const Body& b = model.bodies[body];
  if (b.joint.nv() != 1 || b.joint.nq() != 1)
    throw InputError(where + ": joint '" + actuator.joint + "' has " +
                     std::to_string(b.joint.nv()) +
                     " velocities; actuators drive 1-dof joints (revolute, continuous, prismatic)");
  for (const JointActuator& other : model.actuators)
    if (other.body == body)
      throw InputError(where + ": joint '" + actuator.joint +
                       "' already has an actuator; give one entry its motor and servo together");
  for (const auto& [name, gain] : {std::pair{"kp", actuator.kp}, std::pair{"kd", actuator.kd}})
    if (!(gain >= 0.0 && std::isfinite(gain)))
      throw InputError(where + "." + name + " = " + number(gain) +
                       " must be finite and not negative");
  checkTimeTable(actuator.torque, where + ".torque");
  checkTimeTable(actuator.position, where + ".position");
  checkTimeTable(actuator.velocity, where + ".velocity");
  if (actuator.kp > 0.0 && actuator.position.empty())
    throw InputError(where + ".kp = " + number(actuator.kp) +
                     " needs a target: give `position` (a value or a table)");
  if (!(actuator.max_torque > 0.0))
    throw InputError(where + ".max_torque = " + number(actuator.max_torque) +
                     " must be positive (leave it out for no limit)");
  if (actuator.prescribed && actuator.position.empty())
    throw InputError(where + ": a prescribed motion needs its position (a value or a table)");
  if (actuator.prescribed && (actuator.servo() || !actuator.torque.empty()))
    throw InputError(where + ": a prescribed joint follows its position exactly: it takes no " +
                     "torque and no servo gains");
  if (!actuator.prescribed && actuator.torque.empty() && !actuator.servo())
    throw InputError(where + ": neither a torque nor servo gains (kp, kd); a motor commanded " +
                     "from Python starts from `torque: 0`");
  actuator.body = body;
  actuator.q_index = b.q_index;
  actuator.v_index = b.v_index;
  if (actuator.prescribed) {
    ConstraintFunction motion;
    motion.name = "prescribed " + actuator.joint;
    motion.gap = [q = b.q_index](const VectorX& x) { return x[q]; };
    motion.normal = [v = b.v_index, nv = model.nv](const VectorX&) {
      VectorX w = VectorX::Zero(nv);
      w[v] = 1.0;
      return w;
    };
    motion.bilateral = true;
    motion.drive = [position = actuator.position](double t) { return position.at(t); };
    actuator.constraint = static_cast<int>(model.constraints.size());
    model.constraints.push_back(std::move(motion));
  }
  model.actuators.push_back(std::move(actuator));
}

}  // namespace sweep
