// Joint actuators (framework/actuator.hpp, integrators/actuation.hpp) in both schemes: a motor
// against Newton's law, a servo stiffer than the step can follow, the torque limit, and a
// 6-dof arm tracking a smooth trajectory at kp = 1e5.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "apps/sweep/run.hpp"
#include "apps/sweep/scene_file.hpp"
#include "framework/data.hpp"
#include "framework/error.hpp"
#include "framework/rnea.hpp"
#include "integrators/time_stepper.hpp"

namespace sweep {
namespace {

namespace fs = std::filesystem;

const std::string kUrdfFolder = std::string(SWEEP_SOURCE_DIR) + "/tests/data/urdf/";

class Actuation : public ::testing::TestWithParam<const char*> {
 protected:
  // a turntable (tests/data/urdf/turntable.urdf: I = 0.5 kg m^2, effort 2 N m) with `actuator`
  SceneFile turntable(const std::string& actuator, double h) const {
    std::ostringstream text;
    text << "dimension: 3\nurdf:\n  - file: turntable.urdf\n    actuators: {spin: " << actuator
         << "}\nscheme: {name: " << GetParam() << "}\ntime: {step: " << h << ", end: 1}\n";
    return loadSceneText(text.str(), kUrdfFolder + "actuated.yaml");
  }
};

TEST_P(Actuation, AMotorTurnsTheTableAsNewtonSays) {
  const SceneFile file = turntable("{torque: 1.0}", 1e-3);
  const Scene scene = buildSceneFile(file);
  TimeStepper stepper(scene.model, scene.cmodel, file.run.scheme, scene.forces);
  stepper.reset(0.0, scene.q0, scene.v0);
  for (int k = 0; k < 500; ++k) stepper.step();
  // constant acceleration 1 / 0.5: the midpoint update is exact for it
  const double t = stepper.time();
  EXPECT_NEAR(stepper.q()[0], t * t, 1e-12);
  EXPECT_NEAR(stepper.v()[0], 2.0 * t, 1e-12);
  EXPECT_EQ(stepper.actuatorTorques()[0], 1.0);
}

TEST_P(Actuation, AServoStifferThanTheStepSettles) {
  // omega h = sqrt(1e9 / 0.5) 1e-3 = 45, no damper: an explicit spring would blow up in a few
  // steps, a midpoint (trapezoidal) one would ring for ever; backward Euler's spring decays by
  // a factor 1/sqrt(2) a step in this limit
  const SceneFile file = turntable("{kp: 1.0e9, kd: 0, position: 1, max_torque: 1.0e12}", 1e-3);
  const Scene scene = buildSceneFile(file);
  TimeStepper stepper(scene.model, scene.cmodel, file.run.scheme, scene.forces);
  stepper.reset(0.0, scene.q0, scene.v0);
  double worst = 0.0;
  for (int k = 0; k < 100; ++k) {
    stepper.step();
    worst = std::max(worst, std::abs(stepper.q()[0] - 1.0));
  }
  EXPECT_LE(worst, 1.0);
  EXPECT_NEAR(stepper.q()[0], 1.0, 1e-9);
  EXPECT_NEAR(stepper.v()[0], 0.0, 1e-6);
}

TEST_P(Actuation, TheTorqueLimitHoldsUntilTheServoCanFollow) {
  // the URDF's effort (2 N m) bounds the servo: 4 rad/s^2 until it brakes onto its target
  const SceneFile file = turntable("{kp: 1.0e4, kd: 1000, position: 0.1}", 1e-3);
  const Scene scene = buildSceneFile(file);
  ASSERT_EQ(scene.model.actuators[0].max_torque, 2.0);
  TimeStepper stepper(scene.model, scene.cmodel, file.run.scheme, scene.forces);
  stepper.reset(0.0, scene.q0, scene.v0);
  for (int k = 0; k < 100; ++k) {
    stepper.step();
    ASSERT_TRUE(stepper.actuatorsSaturated()[0]) << "step " << k + 1;
    ASSERT_EQ(stepper.actuatorTorques()[0], 2.0);
  }
  EXPECT_NEAR(stepper.q()[0], 2.0 * 0.1 * 0.1, 1e-12);
  long switches = 0;
  bool last = true;
  for (int k = 0; k < 2900; ++k) {
    stepper.step();
    ASSERT_LE(std::abs(stepper.actuatorTorques()[0]), 2.0 + 1e-12);
    const bool now = stepper.actuatorsSaturated()[0];
    switches += now != last;
    last = now;
  }
  // accelerates, brakes at the limit, then follows: no chattering between the two
  EXPECT_LE(switches, 4);
  EXPECT_FALSE(last);
  EXPECT_NEAR(stepper.q()[0], 0.1, 1e-9);
}

// 1/2 amplitude (1 - cos(pi t / T)) sampled every 5 ms: starts at rest on q = 0
std::string cosineTable(double amplitude, double period) {
  std::ostringstream times, values;
  times.precision(17);
  values.precision(17);
  for (int k = 0; k <= 200; ++k) {
    const double t = period * k / 200.0;
    times << (k ? ", " : "") << t;
    values << (k ? ", " : "") << 0.5 * amplitude * (1.0 - std::cos(M_PI * t / period));
  }
  return "{times: [" + times.str() + "], values: [" + values.str() + "]}";
}

TEST_P(Actuation, ASixDofArmTracksATrajectoryAtKp1e5) {
  const double amplitudes[] = {0.8, 0.4, 0.5, 1.0, 0.5, 1.0};
  const double kd[] = {600, 600, 300, 100, 100, 30};
  std::ostringstream text;
  text << "dimension: 3\ngravity: [0, 0, -9.81]\nurdf:\n  - file: arm6.urdf\n"
          "    position: [0, 0, 0.1]\n    actuators:\n";
  for (int j = 0; j < 6; ++j)
    text << "      joint" << j + 1 << ": {kp: 1.0e5, kd: " << kd[j]
         << ", max_torque: 1.0e4, position: " << cosineTable(amplitudes[j], 1.0) << "}\n";
  text << "scheme: {name: " << GetParam() << "}\ntime: {step: 1.0e-3, end: 1.2}\n"
       << "output: {stats: true}\n";
  const SceneFile file = loadSceneText(text.str(), kUrdfFolder + "arm_tracking.yaml");
  const fs::path out =
      fs::temp_directory_path() / ("sweep_arm_tracking_" + std::string(GetParam()));
  fs::remove_all(out);
  RunOptions options;
  options.out_dir = out.string();
  const RunSummary summary = runScene(buildSceneFile(file), file.run, options);
  ASSERT_EQ(summary.actuators.size(), 6u);
  for (const ActuatorSummary& a : summary.actuators) {
    EXPECT_LT(a.max_tracking_error, 1e-3) << a.joint;
    EXPECT_GT(a.max_abs_torque, 0.0) << a.joint;
    EXPECT_EQ(a.saturated_steps, 0) << a.joint;
  }
  // the files carry the same figures
  std::ifstream summary_file(out / "summary.json");
  const nlohmann::json json = nlohmann::json::parse(summary_file);
  EXPECT_EQ(json["actuators"]["joint2"]["max_tracking_error"].get<double>(),
            summary.actuators[1].max_tracking_error);
  std::ifstream csv(out / "actuators.csv");
  std::string header, line;
  std::getline(csv, header);
  EXPECT_EQ(header.rfind("step,t,joint1:position,joint1:target,joint1:torque,joint1:saturated", 0),
            0u);
  long rows = 0;
  while (std::getline(csv, line)) ++rows;
  EXPECT_EQ(rows, summary.steps);
  fs::remove_all(out);
}

TEST_P(Actuation, TheArmPushesTwoBlocksAcrossTheTable) {
  const std::string path =
      std::string(SWEEP_SOURCE_DIR) + "/examples/archetypes/arm_pushes_blocks.yaml";
  const SceneFile file = loadSceneFile(path, {std::string("scheme.name=") + GetParam()});
  const Scene scene = buildSceneFile(file);
  TimeStepper stepper(scene.model, scene.cmodel, file.run.scheme, scene.forces);
  stepper.reset(0.0, scene.q0, scene.v0);
  ActuatorTally tally(scene.model);
  const long steps = stepCount(0.0, file.run.t_end, file.run.scheme.h);
  for (long k = 0; k < steps; ++k) {
    stepper.step();
    ASSERT_TRUE(stepper.q().allFinite()) << "step " << k + 1;
    tally.add(scene.model, stepper);
  }
  const auto position = [&](const char* body) -> Vector3 {
    return stepper.q().segment<3>(scene.model.bodies[scene.model.bodyIndex(body)].q_index);
  };
  // swept from y = 0 and 0.2 towards +y, each left resting on the table (2 cm half-height)
  EXPECT_GT(position("block_a").y(), 0.15);
  EXPECT_GT(position("block_b").y(), 0.35);
  for (const char* block : {"block_a", "block_b"}) EXPECT_NEAR(position(block).z(), 0.03, 1e-3);
  const std::vector<ActuatorSummary> actuators = tally.summary(scene.model);
  for (std::size_t a = 0; a < actuators.size(); ++a) {
    EXPECT_LE(actuators[a].max_abs_torque, scene.model.actuators[a].max_torque)
        << actuators[a].joint;
    EXPECT_LT(actuators[a].max_tracking_error, 0.05) << actuators[a].joint;
  }
  // joint 1 back on its target once the sweep ends and the wrist has lifted
  EXPECT_NEAR(stepper.q()[scene.model.actuators[0].q_index], 0.6, 1e-3);
}

TEST_P(Actuation, PrescribedJointsFollowTheirMotionAndReportTheirReaction) {
  // joint 1 turns along a ramp, the others are held where the arm is horizontal: at rest the
  // reactions are the gravity torques, and every joint is on its motion at each step's end to
  // the solve's tolerance (1e-6: a few nanoradians, corrected each step, never accumulated)
  std::ostringstream text;
  text << "dimension: 3\ngravity: [0, 0, -9.81]\nurdf:\n  - file: arm6.urdf\n"
          "    position: [0, 0, 0.1]\n    actuators:\n"
          "      joint1: {prescribed: {times: [0, 0.5, 1], values: [0, 0.4, 0.4]}}\n";
  for (int j = 2; j <= 6; ++j) text << "      joint" << j << ": {prescribed: 0}\n";
  text << "scheme: {name: " << GetParam() << "}\ntime: {step: 1.0e-3, end: 1.2}\n";
  const SceneFile file = loadSceneText(text.str(), kUrdfFolder + "arm_prescribed.yaml");
  const Scene scene = buildSceneFile(file);
  ASSERT_EQ(scene.model.constraints.size(), 6u);
  TimeStepper stepper(scene.model, scene.cmodel, file.run.scheme, scene.forces);
  stepper.reset(0.0, scene.q0, scene.v0);
  for (int k = 0; k < 1200; ++k) {
    stepper.step();
    const double t = stepper.time();
    const double q1 = t < 0.5 ? 0.8 * t : 0.4;
    // the kink at t = 0.5 (an impulse) is absorbed over the two steps after it
    const bool kink = t > 0.5 && t < 0.5 + 2.5e-3;
    if (!kink) {
      ASSERT_NEAR(stepper.q()[scene.model.actuators[0].q_index], q1, 1e-7) << "t = " << t;
    }
    for (int a = 1; a < 6; ++a)
      ASSERT_NEAR(stepper.q()[scene.model.actuators[a].q_index], 0.0, 1e-7) << "t = " << t;
  }
  Data data(scene.model);
  const VectorX gravity = gravityForces(scene.model, data, stepper.q());
  for (int a = 0; a < 6; ++a) {
    const JointActuator& actuator = scene.model.actuators[a];
    EXPECT_NEAR(stepper.actuatorTorques()[a], gravity[actuator.v_index],
                1e-4 * gravity.cwiseAbs().maxCoeff())
        << actuator.joint;
  }
  EXPECT_GT(gravity.cwiseAbs().maxCoeff(), 1.0);
}

// The UR10, KR5 and WAM from their description packages' layout (tests/data/packages: the
// published kinematics, inertias and limits, stand-in meshes), their joints held by servos for
// 1 s: settled on the gravity torques, within the servos' limits, no energy gained, and the
// free-standing KR5 upright on its base's corners.
TEST_P(Actuation, RealRobotsStandOnTheFloorOnTheirServos) {
  const std::string packages = std::string(SWEEP_SOURCE_DIR) + "/tests/data/packages";
  // the KR5's scene finds its package through the environment, as ROS tools do
  const char* saved = std::getenv("ROS_PACKAGE_PATH");
  const std::string previous = saved ? saved : "";
  setenv("ROS_PACKAGE_PATH", (packages + "/src").c_str(), 1);
  for (const char* robot : {"ur10", "kr5", "wam"}) {
    SCOPED_TRACE(robot);
    const SceneFile file = loadSceneFile(packages + "/scenes/" + robot + "_on_floor.yaml",
                                         {std::string("scheme.name=") + GetParam()});
    const Scene scene = buildSceneFile(file);
    TimeStepper stepper(scene.model, scene.cmodel, file.run.scheme, scene.forces);
    stepper.reset(0.0, scene.q0, scene.v0);
    ActuatorTally tally(scene.model);
    double start = -1.0, highest = -1.0;
    for (int k = 0; k < 1000; ++k) {
      stepper.step();
      ASSERT_TRUE(stepper.q().allFinite()) << "step " << k + 1;
      tally.add(scene.model, stepper);
      const double energy = stepper.stats().kinetic + stepper.stats().potential;
      if (k == 0) start = energy;
      highest = std::max(highest, energy);
    }
    // the servos' dampers only take energy out
    EXPECT_LE(highest, start + 1e-9 * std::abs(start));
    EXPECT_LT(stepper.v().cwiseAbs().maxCoeff(), 1e-3);
    Data data(scene.model);
    const VectorX gravity = gravityForces(scene.model, data, stepper.q());
    const std::vector<ActuatorSummary> actuators = tally.summary(scene.model);
    for (std::size_t a = 0; a < actuators.size(); ++a) {
      const JointActuator& actuator = scene.model.actuators[a];
      EXPECT_EQ(actuators[a].saturated_steps, 0) << actuator.joint;
      // a servo sags by its load over kp: 1.2e-3 rad at the UR10's shoulder (115 N m, 1e5)
      EXPECT_LT(actuators[a].max_tracking_error, 1.5e-3) << actuator.joint;
      // at rest each servo carries its joint's gravity torque (the KR5's floor pushes on its
      // base only, which no arm joint moves)
      EXPECT_NEAR(stepper.actuatorTorques()[a], gravity[actuator.v_index],
                  1e-3 * gravity.cwiseAbs().maxCoeff())
          << actuator.joint;
    }
    if (std::string(robot) == "kr5") {
      const Body& base = scene.model.bodies[scene.model.bodyIndex("base_link")];
      ASSERT_EQ(base.joint.type, JointType::Floating);
      EXPECT_NEAR(stepper.q()[base.q_index + 2], 0.0, 1e-4);  // height: within the margin
      EXPECT_LT(stepper.q().segment<3>(base.q_index + 3).norm(), 1e-4);  // upright
      EXPECT_GE(stepper.stats().active, 3);  // of its four corners: one may rest at a zero gap
    }
  }
  if (saved)
    setenv("ROS_PACKAGE_PATH", previous.c_str(), 1);
  else
    unsetenv("ROS_PACKAGE_PATH");
}

// The WAM's URDF efforts (1.8 N m on its shoulder) cannot hold its arm: the servos sit at their
// limit and the run says so in its closing lines.
TEST_P(Actuation, TheUrdfsEffortsAsLimitsAreReportedWhenTheServosSitAtThem) {
  const std::string packages = std::string(SWEEP_SOURCE_DIR) + "/tests/data/packages";
  const std::string path = packages + "/scenes/wam_on_floor.yaml";
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  const std::string without_limits =
      std::regex_replace(text.str(), std::regex(", max_torque: [0-9.]+"), "") +
      "scheme: {name: " + GetParam() + "}\n";
  const SceneFile file = loadSceneText(without_limits, path);
  const Scene scene = buildSceneFile(file);
  EXPECT_EQ(scene.model.actuators[1].max_torque, 1.8);
  TimeStepper stepper(scene.model, scene.cmodel, file.run.scheme, scene.forces);
  stepper.reset(0.0, scene.q0, scene.v0);
  ActuatorTally tally(scene.model);
  for (int k = 0; k < 200; ++k) {
    stepper.step();
    tally.add(scene.model, stepper);
  }
  const std::vector<ActuatorSummary> actuators = tally.summary(scene.model);
  EXPECT_GT(actuators[1].saturated_steps, 150);
  const std::string note = saturationNote(actuators, 200);
  EXPECT_NE(note.find("/j2 " + std::to_string(actuators[1].saturated_steps) +
                      " of 200 steps (|tau| <= 1.8)"),
            std::string::npos)
      << note;
  EXPECT_EQ(saturationNote({}, 200), "");
}

INSTANTIATE_TEST_SUITE_P(BothSchemes, Actuation, ::testing::Values("moreau-jean", "catching-up"),
                         [](const ::testing::TestParamInfo<const char*>& param) {
                           return std::string(param.param) == "moreau-jean" ? "MoreauJean"
                                                                            : "CatchingUp";
                         });

}  // namespace
}  // namespace sweep
