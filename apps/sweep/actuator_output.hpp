#pragma once
// What a run writes about its actuators (framework/actuator.hpp): actuators.csv, step by step,
// and the figures summary.json holds.
#include <nlohmann/json.hpp>
#include <ostream>
#include <string>
#include <vector>

#include "integrators/time_stepper.hpp"

namespace sweep {

// What a run's actuators did, each over the run: the largest torque (force) applied, the
// largest distance of its joint from its servo's target at a step's end (0: no target), the
// steps it spent at its torque limit (max_torque)
struct ActuatorSummary {
  std::string joint;
  double max_abs_torque = 0.0, max_tracking_error = 0.0, max_torque = 0.0;
  long saturated_steps = 0;
};

class ActuatorTally {
 public:
  explicit ActuatorTally(const Model& model);
  void add(const Model& model, const TimeStepper& stepper);  // after each step
  std::vector<ActuatorSummary> summary(const Model& model) const;

 private:
  std::vector<ActuatorSummary> rows_;
};

// actuators.csv's header and one row after each step
void writeActuatorHeader(std::ostream& out, const Model& model);
void appendActuatorRow(std::ostream& out, const Model& model, const TimeStepper& stepper);

// The run's closing line on the actuators that spent steps at their torque limit ("" when none
// did): a URDF's effort may be a motor's torque before its gears, far below the joint's.
std::string saturationNote(const std::vector<ActuatorSummary>& actuators, long steps);

// summary.json's "actuators": {JOINT: {max_abs_torque, max_tracking_error, saturated_steps}}
nlohmann::ordered_json actuatorsJson(const std::vector<ActuatorSummary>& actuators);

}  // namespace sweep
