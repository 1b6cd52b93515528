#include "apps/sweep/actuator_output.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "apps/sweep/run.hpp"

namespace sweep {

// actuators.csv: per step, each actuator's joint position, target (empty: none), torque (force)
// applied over the step, and whether the step held it at its limit
void writeActuatorHeader(std::ostream& out, const Model& model) {
  out << "step,t";
  for (const JointActuator& a : model.actuators)
    out << ',' << a.joint << ":position," << a.joint << ":target," << a.joint << ":torque,"
        << a.joint << ":saturated";
  out << '\n';
}

void appendActuatorRow(std::ostream& out, const Model& model, const TimeStepper& stepper) {
  out << stepper.stats().step << ',' << exactNumber(stepper.time());
  for (std::size_t a = 0; a < model.actuators.size(); ++a) {
    const double target = stepper.actuatorTargets()[a];
    out << ',' << exactNumber(stepper.q()[model.actuators[a].q_index]) << ','
        << (std::isnan(target) ? std::string() : exactNumber(target)) << ','
        << exactNumber(stepper.actuatorTorques()[a]) << ','
        << (stepper.actuatorsSaturated()[a] ? 1 : 0);
  }
  out << '\n';
}

ActuatorTally::ActuatorTally(const Model& model) : rows_(model.actuators.size()) {}

void ActuatorTally::add(const Model& model, const TimeStepper& stepper) {
  for (std::size_t a = 0; a < rows_.size(); ++a) {
    ActuatorSummary& row = rows_[a];
    row.max_abs_torque = std::max(row.max_abs_torque, std::abs(stepper.actuatorTorques()[a]));
    const double target = stepper.actuatorTargets()[a];
    if (!std::isnan(target))
      row.max_tracking_error = std::max(row.max_tracking_error,
                                        std::abs(stepper.q()[model.actuators[a].q_index] - target));
    row.saturated_steps += stepper.actuatorsSaturated()[a] ? 1 : 0;
  }
}

std::vector<ActuatorSummary> ActuatorTally::summary(const Model& model) const {
  std::vector<ActuatorSummary> rows = rows_;
  for (std::size_t a = 0; a < rows.size(); ++a) {
    rows[a].joint = model.actuators[a].joint;
    rows[a].max_torque = model.actuators[a].max_torque;
  }
  return rows;
}

std::string saturationNote(const std::vector<ActuatorSummary>& actuators, long steps) {
  std::ostringstream note;
  note << std::setprecision(4);
  for (const ActuatorSummary& a : actuators) {
    if (a.saturated_steps == 0) continue;
    note << (note.tellp() > 0 ? ", " : "") << a.joint << " " << a.saturated_steps << " of " << steps
         << " steps (|tau| <= " << a.max_torque << ")";
  }
  if (note.tellp() == 0) return "";
  return "  actuators at their torque limit: " + note.str() +
         "; urdf[].actuators.JOINT.max_torque sets a limit other than the URDF's effort\n";
}

nlohmann::ordered_json actuatorsJson(const std::vector<ActuatorSummary>& list) {
  nlohmann::ordered_json actuators = nlohmann::ordered_json::object();
  for (const ActuatorSummary& a : list)
    actuators[a.joint] = {{"max_abs_torque", a.max_abs_torque},
                          {"max_tracking_error", a.max_tracking_error},
                          {"saturated_steps", a.saturated_steps}};
  return actuators;
}

}  // namespace sweep
