// Both schemes over MPI ranks (integrators/distributed_stepper.hpp) against the single process.
// Runs in the distributed_tests binary on 1 to 4 ranks; every rank builds the same scene and
// calls the collectives in the same order, and checks with EXPECT only.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>

#include "framework/error.hpp"
#include "integrators/distributed_stepper.hpp"
#include "integrators/time_stepper.hpp"
#include "models/scene_spec.hpp"

namespace sweep {
namespace {

constexpr double kRadius = 1e-3;

// Spheres of radius 1 mm on a lattice of pitch 2.1 mm, jittered, every other layer shifted by
// half a pitch so that it falls into the hollows of the one below: nx x ny x layers, falling
// onto a floor between two walls at y = 0 and y = width; along x either two more walls or a
// period of nx pitches. Frictional and inelastic.
Scene fallingSpheres(int nx, int ny, int layers, bool periodic_x) {
  SceneSpec spec;
  spec.dimension = 3;
  spec.gravity = Vector3(0.0, 0.0, -9.81);
  spec.materials.push_back({"glass", 2500.0});
  spec.default_law = ContactLaw{0.4, 0.0};
  const double pitch = 2.1 * kRadius;
  const double length = nx * pitch, width = ny * pitch;
  auto wall = [&](const std::string& name, const Vector3& at, const Vector3& normal) {
    BodySpec body;
    body.name = name;
    body.kind = BodySpec::Kind::Fixed;
    body.shape = Shape::halfSpace();
    body.pose.translation = at;
    body.pose.rotation =
        Eigen::Quaterniond::FromTwoVectors(Vector3::UnitZ(), normal).toRotationMatrix();
    spec.bodies.push_back(body);
  };
  wall("floor", Vector3::Zero(), Vector3::UnitZ());
  wall("front", Vector3::Zero(), Vector3::UnitY());
  wall("back", Vector3(0.0, width, 0.0), -Vector3::UnitY());
  if (periodic_x) {
    spec.detection.periodic.axis = 0;
    spec.detection.periodic.low = 0.0;
    spec.detection.periodic.high = length;
  } else {
    wall("left", Vector3::Zero(), Vector3::UnitX());
    wall("right", Vector3(length, 0.0, 0.0), -Vector3::UnitX());
  }
  std::mt19937 random(7);
  std::uniform_real_distribution<double> jitter(0.0, 0.05 * kRadius);
  for (int layer = 0; layer < layers; ++layer)
    for (int j = 0; j < ny - layer % 2; ++j)
      for (int i = 0; i < nx - (periodic_x ? 0 : layer % 2); ++i) {
        const double shift = 0.5 * pitch * (layer % 2);
        BodySpec sphere;
        sphere.name = "s" + std::to_string(spec.bodies.size());
        sphere.shape = Shape::sphere(kRadius);
        sphere.material = "glass";
        sphere.pose.translation = Vector3((i + 0.5) * pitch + shift + jitter(random),
                                          (j + 0.5) * pitch + shift + jitter(random),
                                          kRadius * 1.02 + layer * pitch + jitter(random));
        spec.bodies.push_back(sphere);
      }
  return buildScene(spec);
}

SchemeSettings settingsFor() {
  SchemeSettings s;
  s.scheme = Scheme::MoreauJean;
  s.h = 2e-4;
  s.normal_law = NormalLaw::Vel;
  s.coulomb.tolerance = 1e-9;
  s.coulomb.max_iterations = 20000;
  return s;
}

struct State {
  VectorX q, v;
};

State serialRun(const Scene& scene, const SchemeSettings& settings, int steps) {
  TimeStepper stepper(scene.model, scene.cmodel, settings);
  stepper.reset(0.0, scene.q0, scene.v0);
  for (int k = 0; k < steps; ++k) stepper.step();
  return {stepper.q(), stepper.v()};
}

State distributedRun(const RankGroup& ranks, const Scene& scene, const SchemeSettings& settings,
                     int steps, DistributedSettings distributed = {},
                     std::int64_t* shared = nullptr) {
  DistributedStepper stepper(ranks, scene.model, scene.cmodel, settings, distributed);
  stepper.reset(0.0, scene.q0, scene.v0);
  std::int64_t most_shared = 0;
  for (int k = 0; k < steps; ++k) {
    stepper.step();
    most_shared = std::max(most_shared, stepper.distributedStats().shared_bodies);
  }
  if (shared) *shared = most_shared;
  State out;
  stepper.gatherState(out.q, out.v);
  return out;
}

// the largest centre distance and speed difference between two runs
void compare(const Scene& scene, const State& a, const State& b, double& position, double& speed) {
  position = speed = 0.0;
  for (const Body& body : scene.model.bodies) {
    position =
        std::max(position, (a.q.segment<3>(body.q_index) - b.q.segment<3>(body.q_index)).norm());
    speed = std::max(speed, (a.v.segment<3>(body.v_index) - b.v.segment<3>(body.v_index)).norm());
  }
}

// Through the first impacts and into the closing pile (100 steps, up to 250 closed contacts):
// the solve across ranks reaches the solver's tolerance, so the runs agree to round-off far
// below a grain's size. With one rank the run is the single process's, to the bit. (At step
// 106 the pile's frictional problem has two solutions 3e-4 m/s apart: the single process picks
// the other one too when its sweep order is shuffled, so the comparison stops before it.)
void expectAgreement(const SchemeSettings& settings, const DistributedSettings& distributed,
                     const char* what, bool periodic = false, int steps = 100) {
  const RankGroup ranks = RankGroup::world();
  const Scene scene = periodic ? fallingSpheres(16, 3, 2, true) : fallingSpheres(12, 4, 3, false);
  const State serial = serialRun(scene, settings, steps);
  std::int64_t shared = 0;
  const State spread = distributedRun(ranks, scene, settings, steps, distributed, &shared);
  double position = 0.0, speed = 0.0;
  compare(scene, serial, spread, position, speed);
  if (ranks.size() == 1) {
    EXPECT_EQ(position, 0.0) << what;
    EXPECT_EQ(speed, 0.0) << what;
  } else {
    EXPECT_GT(shared, 0) << "no body was shared: the test does not reach the interface";
    EXPECT_LT(position, 1e-7 * kRadius) << what << ", ranks " << ranks.size();
    EXPECT_LT(speed, 1e-7) << what << ", ranks " << ranks.size();
  }
  std::printf(
      "[ranks %d] %s: largest difference to the single process %.3g m, %.3g m/s; "
      "shared bodies %lld\n",
      ranks.size(), what, position, speed, static_cast<long long>(shared));
}

TEST(DistributedStepper, OrderedSweepsAgreeWithTheSingleProcess) {
  expectAgreement(settingsFor(), {}, "ordered sweeps");
}

TEST(DistributedStepper, OrderedSweepsWithNncgAgreeWithTheSingleProcess) {
  SchemeSettings settings = settingsFor();
  settings.coulomb.acceleration = NlgsAcceleration::Nncg;
  expectAgreement(settings, {}, "ordered sweeps, NNCG", true);
}

// Scheme B's two stages by NLGS at the comparison's tolerance
SchemeSettings schemeBSettings(NormalLaw law) {
  SchemeSettings s = settingsFor();
  s.scheme = Scheme::CatchingUp;
  s.normal_law = law;
  for (SolverSettings* stage : {&s.normal_stage, &s.friction_stage}) {
    stage->solver = StageSolver::Nlgs;
    stage->tolerance = 1e-9;
    stage->max_iterations = 20000;
  }
  return s;
}

// 80 steps: from step 81 on, stage 5b's problem in the closed pile has several solutions (the
// single process lands 5.6e-8 m and 2.8e-4 m/s away at step 90 with its rows shuffled)
TEST(DistributedStepper, SchemeBAgreesWithTheSingleProcess) {
  expectAgreement(schemeBSettings(NormalLaw::Vel), {}, "scheme B, VEL", false, 80);
}

// IQS leaves the closed rows a bias: stage 5b projects v1 on the closed normals, by conjugate
// gradients across the ranks
TEST(DistributedStepper, SchemeBWithItsProjectionAndNncgAgreesWithTheSingleProcess) {
  SchemeSettings settings = schemeBSettings(NormalLaw::Iqs);
  settings.normal_stage.acceleration = settings.friction_stage.acceleration =
      NlgsAcceleration::Nncg;
  expectAgreement(settings, {}, "scheme B, IQS, NNCG", true);
}

// One layer under a ghost band of one radius, half a diameter, its grains thrown about at up
// to 0.3 m/s along each axis: the first step's reach (a diameter and its margin) outgrows the
// band and its ghosts come again from a wider band. Every step the ranks together find the
// single process's candidates, and the run ends where the single process's does.
TEST(DistributedStepper, ANarrowGhostBandWidensWithTheMargin) {
  const RankGroup ranks = RankGroup::world();
  Scene scene = fallingSpheres(12, 4, 1, false);
  std::mt19937 random(11);
  std::uniform_real_distribution<double> thrown(-0.3, 0.3);
  for (const Body& body : scene.model.bodies)
    for (int k = 0; k < 3; ++k) scene.v0[body.v_index + k] = thrown(random);
  const SchemeSettings settings = settingsFor();
  TimeStepper serial(scene.model, scene.cmodel, settings);
  serial.reset(0.0, scene.q0, scene.v0);
  DistributedSettings distributed;
  distributed.ghost_width = kRadius;
  DistributedStepper spread(ranks, scene.model, scene.cmodel, settings, distributed);
  spread.reset(0.0, scene.q0, scene.v0);
  int widenings = 0;
  for (int k = 0; k < 40; ++k) {
    const int candidates = serial.step().candidates;
    EXPECT_EQ(spread.step().candidates, candidates) << "step " << k + 1;
    widenings += spread.distributedStats().ghost_widenings;
  }
  EXPECT_GT(widenings, 0) << "the band never had to widen";
  State end;
  spread.gatherState(end.q, end.v);
  double position = 0.0, speed = 0.0;
  compare(scene, {serial.q(), serial.v()}, end, position, speed);
  EXPECT_LT(position, 1e-7 * kRadius) << "ranks " << ranks.size();
  EXPECT_LT(speed, 1e-7) << "ranks " << ranks.size();
  std::printf("[ranks %d] narrow ghost band: %d widenings, %.3g m, %.3g m/s\n", ranks.size(),
              widenings, position, speed);
}

TEST(DistributedStepper, SplitMassesAgreeWithTheSingleProcess) {
  DistributedSettings distributed;
  distributed.interface = RankInterface::SplitMasses;
  expectAgreement(settingsFor(), distributed, "split masses");
}

// A bed periodic along x whose period spans the ranks, rebalanced as it goes.
TEST(DistributedStepper, PeriodicBedAgreesAndRepeatsToTheBit) {
  const RankGroup ranks = RankGroup::world();
  const Scene scene = fallingSpheres(16, 3, 2, true);
  const SchemeSettings settings = settingsFor();
  const int steps = 120;
  DistributedSettings distributed;
  distributed.rebalance_interval = 20;
  const State serial = serialRun(scene, settings, steps);
  const State first = distributedRun(ranks, scene, settings, steps, distributed);
  const State again = distributedRun(ranks, scene, settings, steps, distributed);
  double position = 0.0, speed = 0.0;
  compare(scene, first, again, position, speed);
  EXPECT_EQ(position, 0.0);
  EXPECT_EQ(speed, 0.0);
  compare(scene, serial, first, position, speed);
  EXPECT_LT(position, 1e-7 * kRadius) << "ranks " << ranks.size();
  EXPECT_LT(speed, 1e-7) << "ranks " << ranks.size();
  std::printf(
      "[ranks %d] periodic bed: largest difference to the single process %.3g m, "
      "%.3g m/s\n",
      ranks.size(), position, speed);
}

// Cut again by work at every step, the cuts move and contacts change rank: each takes its
// impulse and frame to its new owner, so the ranks together find as many contacts of the last
// step as the single process does, step by step.
TEST(DistributedStepper, RebalancedContactsKeepTheirWarmStarts) {
  const RankGroup ranks = RankGroup::world();
  const Scene scene = fallingSpheres(16, 3, 2, true);
  const SchemeSettings settings = settingsFor();
  DistributedSettings distributed;
  distributed.rebalance_interval = 1;
  distributed.rebalance_above = 0.0;
  TimeStepper serial(scene.model, scene.cmodel, settings);
  serial.reset(0.0, scene.q0, scene.v0);
  DistributedStepper stepper(ranks, scene.model, scene.cmodel, settings, distributed);
  stepper.reset(0.0, scene.q0, scene.v0);
  std::int64_t handed_over = 0, carried = 0, carried_serial = 0;
  for (int k = 0; k < 120; ++k) {
    serial.step();
    stepper.step();
    std::int64_t matched = 0;
    for (const Contact& contact : serial.contactData().contacts)
      matched += contact.previous >= 0 ? 1 : 0;
    EXPECT_EQ(stepper.distributedStats().carried, matched) << "step " << k;
    carried += stepper.distributedStats().carried;
    carried_serial += matched;
    handed_over += stepper.distributedStats().handed_over;
  }
  EXPECT_GT(carried_serial, 1000);
  if (ranks.size() > 1) {
    EXPECT_GT(handed_over, 0) << "ranks " << ranks.size();
  }
  std::printf(
      "[ranks %d] rebalanced every step: %lld contacts carried (single process %lld), "
      "%lld handed over\n",
      ranks.size(), static_cast<long long>(carried), static_cast<long long>(carried_serial),
      static_cast<long long>(handed_over));
}

// Bad balance settings are refused naming the field.
TEST(DistributedStepper, RefusesBadRebalanceSettings) {
  const RankGroup ranks = RankGroup::world();
  const Scene scene = fallingSpheres(2, 2, 1, false);
  for (const double above : {-1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    DistributedSettings distributed;
    distributed.rebalance_above = above;
    try {
      DistributedStepper stepper(ranks, scene.model, scene.cmodel, settingsFor(), distributed);
      ADD_FAILURE() << "rebalance_above " << above << " was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("rebalance_above"), std::string::npos) << e.what();
    }
  }
}

TEST(DistributedStepper, RefusesWhatDoesNotRunOnRanks) {
  const RankGroup ranks = RankGroup::world();
  const Scene scene = fallingSpheres(2, 2, 1, false);
  SchemeSettings settings = settingsFor();
  settings.scheme = Scheme::CatchingUp;
  settings.friction_stage.solver = StageSolver::Mprgp;
  try {
    DistributedStepper stepper(ranks, scene.model, scene.cmodel, settings);
    ADD_FAILURE() << "scheme B's MPRGP was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("scheme.friction_stage.solver"), std::string::npos)
        << e.what();
  }
  settings.friction_stage.solver = StageSolver::Auto;
  DistributedSettings split;
  split.interface = RankInterface::SplitMasses;
  try {
    DistributedStepper stepper(ranks, scene.model, scene.cmodel, settings, split);
    ADD_FAILURE() << "scheme B with split masses was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("interface"), std::string::npos) << e.what();
  }
  settings = settingsFor();
  settings.projection.max_rounds = 1;
  try {
    DistributedStepper stepper(ranks, scene.model, scene.cmodel, settings);
    ADD_FAILURE() << "position projection was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("projection"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace sweep
