// The validation cases against their references (issue #7, docs/validation.md).
#include "apps/sweep/validation.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "apps/sweep/scene_file.hpp"

namespace sweep {
namespace {

// An example of examples/archetypes/ run by `scheme`: the scene file (with --set-style
// overrides), its scene, and a stepper at the initial state.
struct ExampleRun {
  ExampleRun(const std::string& name, Scheme scheme, const std::vector<std::string>& overrides = {})
      : file(load(name, scheme, overrides)),
        scene(buildSceneFile(file)),
        stepper(scene.model, scene.cmodel, file.run.scheme, scene.forces) {
    stepper.reset(0.0, scene.q0, scene.v0);
  }
  static SceneFile load(const std::string& name, Scheme scheme,
                        const std::vector<std::string>& overrides) {
    SceneFile f =
        loadSceneFile(SWEEP_SOURCE_DIR "/examples/archetypes/" + name + ".yaml", overrides);
    f.run.scheme.scheme = scheme;
    return f;
  }
  SceneFile file;
  Scene scene;
  TimeStepper stepper;
};

// The event-driven reference (CVODE with root finding on the gap) hits V1's analytic impact
// times; CVODE runs at rtol 1e-12, so 1e-9 s leaves room for the root finder's own tolerance.
TEST(BouncingBallReference, ImpactTimesAreAnalytic) {
  const BouncingBallParameters ball;
  const std::vector<double> reference = bouncingBallReferenceImpacts(ball, 3.3);
  const std::vector<double> analytic = bouncingBallImpactTimes(ball, 5);
  ASSERT_EQ(reference.size(), 5u);  // 0.4515, 1.2643, 1.9957, 2.6541, 3.2465
  for (int n = 0; n < 5; ++n) EXPECT_NEAR(reference[n], analytic[n], 1e-9) << "impact " << n;
}

// Zeno: the impacts accumulate at t_inf = t1 (1 + e) / (1 - e) = 8.579 s. The reference
// follows them until a rebound is slower than 1e-5 m/s (the flights left to t_inf then last
// 2 v / (g (1 - e)) = 2e-5 s in all), then closes the contact: the ball rests on the floor,
// pushed by m g, to the end of the run.
TEST(BouncingBallReference, ImpactsAccumulateAtTheZenoTimeThenTheBallRests) {
  const BouncingBallParameters ball;
  const std::vector<double> reference = bouncingBallReferenceImpacts(ball, 10.0);
  const double t1 = std::sqrt(2.0 * ball.drop / ball.gravity);
  const double t_inf = t1 * (1.0 + ball.restitution) / (1.0 - ball.restitution);
  ASSERT_GT(reference.size(), 100u);
  EXPECT_NEAR(reference.back(), t_inf, 2.1e-5);
  EXPECT_LT(reference.back(), t_inf);

  const Scene scene = bouncingBall(ball);
  const UnilateralConstraint floor = bouncingBallConstraints(ball)[0];
  EventDrivenReference rest(scene.model, {floor});
  rest.reset(0.0, scene.q0, scene.v0);
  rest.advanceTo(10.0);
  EXPECT_TRUE(rest.accumulated());
  EXPECT_TRUE(rest.closed(0));
  EXPECT_DOUBLE_EQ(rest.time(), 10.0);
  EXPECT_NEAR(floor.gap(rest.q()), 0.0, 1e-9);
  EXPECT_LT(rest.v().norm(), 1e-9);
  ASSERT_EQ(rest.phases().size(), 1u);
  EXPECT_NEAR(rest.phases()[0].t_close, t_inf, 2.1e-5);
}

// Both schemes converge to the reference at first order, as the reference (6, V1) states:
// halving h halves the error. Seven step sizes from the Siconos h = 0.005 down to h / 64;
// the fitted order must lie within 0.3 of 1 (the local orders scatter between -0.3 and 1.5
// because of where the impacts fall inside the steps; the fit over six halvings is ~0.9).
class Archetypes : public ::testing::TestWithParam<Scheme> {};

TEST_P(Archetypes, BouncingBallFirstOrderAgainstTheEventDrivenReference) {
  std::vector<double> steps;
  for (int k = 0; k < 7; ++k) steps.push_back(5e-3 / std::pow(2.0, k));
  const std::vector<ConvergencePoint> points =
      bouncingBallConvergence(BouncingBallParameters{}, GetParam(), steps, 3.0, 5e-3);
  ASSERT_EQ(points.size(), steps.size());
  const double order = fittedOrder(points);
  EXPECT_GT(order, 0.7);
  EXPECT_LT(order, 1.3);
  // and the error at h / 64 is at least 20 times smaller than at h
  EXPECT_LT(points.back().error, points.front().error / 20.0);
}

// The runnable example, examples/archetypes/bouncing_ball.yaml, is the same V1: each scheme
// finds its first four impacts on the steps of the Siconos reference (0.455, 1.270, 2.005,
// 2.670 s at h = 0.005; the impact step is the one that reverses the fall, reported at its
// midpoint), and the ball ends at rest on the floor. At rest it keeps the penetration of its
// last bounce (the VEL law does not push it out): below v h / 2 for a bounce too short to
// leave the floor for a whole step, v < g h / 2 = 0.025 m/s, i.e. 6e-5 m.
TEST_P(Archetypes, BouncingBallExampleHitsTheSiconosImpactSteps) {
  ExampleRun run("bouncing_ball", GetParam());
  const SceneFile& file = run.file;
  TimeStepper& stepper = run.stepper;
  const double h = file.run.scheme.h;
  ASSERT_EQ(h, 0.005);
  std::vector<double> impacts;
  while (stepper.time() < file.run.t_end - 0.5 * h) {
    const double vz = stepper.v()[2];
    stepper.step();
    if (vz < -0.5 && stepper.v()[2] > 0.0) impacts.push_back(stepper.time() - 0.5 * h);
  }
  const double siconos[] = {0.455, 1.270, 2.005, 2.670};
  ASSERT_GE(impacts.size(), 4u);
  for (int n = 0; n < 4; ++n) EXPECT_NEAR(impacts[n], siconos[n] - 0.5 * h, 1e-9) << n;
  EXPECT_LT(stepper.v().norm(), 1e-9);
  EXPECT_LE(stepper.q()[2], 0.1 + 1e-12);
  EXPECT_GT(stepper.q()[2], 0.1 - 0.5 * 0.025 * h);
}

// V4 from examples/archetypes/disk_on_incline.yaml: rolling at 2/3 g sin a with mu = 0.25,
// sliding at g (sin a - mu cos a) with mu = 0.1 (threshold tan(a) / 3 = 0.2). The disk
// starts exactly tangent, so the first step's midpoint gap is not negative and it falls
// freely for one step; the contact takes over in the second. The acceleration is measured
// over the 400 steps after those two; both laws are exact for the discrete scheme (constant
// acceleration), so 1e-9 is round-off.
TEST_P(Archetypes, DiskOnInclineExampleRollsOrSlides) {
  const double g = 9.81, sin_a = 0.6 / std::sqrt(1.36), cos_a = 1.0 / std::sqrt(1.36);
  const Vector3 down(-cos_a, -sin_a, 0.0);
  for (double mu : {0.25, 0.1}) {
    ExampleRun run("disk_on_incline", GetParam(), {"contact.friction=" + std::to_string(mu)});
    TimeStepper& stepper = run.stepper;
    const double h = run.file.run.scheme.h;
    stepper.step();
    stepper.step();
    const double v0 = stepper.v().head<3>().dot(down);
    for (int k = 0; k < 400; ++k) stepper.step();
    const double acceleration = (stepper.v().head<3>().dot(down) - v0) / (400 * h);
    const double expected = mu >= 0.2 ? 2.0 / 3.0 * g * sin_a : g * (sin_a - mu * cos_a);
    EXPECT_NEAR(acceleration, expected, 1e-9) << "mu " << mu;
  }
}

// V6 from examples/archetypes/newtons_cradle.yaml: touching balls, one step, Jean-Moreau's
// simultaneous law gives (-1/3, 2/3, 2/3); spaced 0.05 apart, two sequential impacts give
// (0, 0, 1), in both schemes (1e-10: the solver tolerance is 1e-14, relative).
TEST_P(Archetypes, NewtonsCradleExample) {
  auto velocities = [&](const std::vector<std::string>& overrides, int steps) {
    ExampleRun run("newtons_cradle", GetParam(), overrides);
    for (int k = 0; k < steps; ++k) run.stepper.step();
    const VectorX& v = run.stepper.v();
    return Vector3(v[0], v[3], v[6]);
  };
  if (GetParam() == Scheme::MoreauJean) {
    const Vector3 simultaneous = velocities({}, 1);
    EXPECT_LT((simultaneous - Vector3(-1.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0)).norm(), 1e-10);
  }
  const Vector3 sequential =
      velocities({"bodies[1].position=[1.05,0]", "bodies[2].position=[2.1,0]"}, 200);
  EXPECT_LT((sequential - Vector3(0.0, 0.0, 1.0)).norm(), 1e-10);
}

// V5: the first corner impact of Housner's rocking block. The reference predicts the stick
// thresholds: mu >= 0.45 for Jean-Moreau (the classical impulse (P_T, P_N) = (-0.346, 0.769)
// per unit omega-), mu >= 0.666 for the staggered scheme (its frictionless stage-1 impulse
// 0.52 is what sets the friction bound). Bracketed at +-0.01 and +-0.014: below, the corner
// slides and the ratio falls short of Housner's; above, the corner holds (slip < 1e-8 m) and
// the ratio is Housner's up to the block's own rotation during the impact step, O(h):
// 4.3e-4 at h = 1e-4, so 1e-3.
TEST(RockingBlock, StickThresholdsOfBothSchemes) {
  struct Case {
    Scheme scheme;
    double mu;
    bool sticks;
  };
  const Case cases[] = {{Scheme::MoreauJean, 0.44, false},
                        {Scheme::MoreauJean, 0.46, true},
                        {Scheme::CatchingUp, 0.46, false},
                        {Scheme::CatchingUp, 0.652, false},
                        {Scheme::CatchingUp, 0.68, true}};
  for (const Case& c : cases) {
    RockingBlockParameters parameters;
    parameters.friction = c.mu;
    const RockingImpact impact = rockingBlockFirstImpact(parameters, c.scheme, 1e-4);
    const double housner = housnerRatio(parameters);
    if (c.sticks) {
      EXPECT_NEAR(impact.ratio, housner, 1e-3) << enumName(c.scheme) << " mu " << c.mu;
      EXPECT_LT(impact.corner_slip, 1e-8) << enumName(c.scheme) << " mu " << c.mu;
    } else {
      EXPECT_LT(impact.ratio, housner - 0.005) << enumName(c.scheme) << " mu " << c.mu;
      EXPECT_GT(impact.corner_slip, 1e-7) << enumName(c.scheme) << " mu " << c.mu;
    }
  }
}

// With threshold updates (ten rounds of stage 5b, thresholds from the last round's total
// normal impulse) the staggered scheme's stick threshold is Jean-Moreau's: the corner slides
// at 0.44 and holds at 0.46, with Jean-Moreau's ratio (0.538030) to 1e-9 where it holds.
TEST(RockingBlock, ThresholdUpdatesGiveJeanMoreausStickThreshold) {
  for (double mu : {0.44, 0.46, 0.6}) {
    RockingBlockParameters parameters;
    parameters.friction = mu;
    const RockingImpact updated = rockingBlockFirstImpact(parameters, Scheme::CatchingUp, 1e-4, 10);
    const RockingImpact coupled = rockingBlockFirstImpact(parameters, Scheme::MoreauJean, 1e-4);
    const double housner = housnerRatio(parameters);
    if (mu > 0.45) {
      EXPECT_NEAR(updated.ratio, housner, 1e-3) << mu;
      EXPECT_LT(updated.corner_slip, 1e-8) << mu;
      EXPECT_NEAR(updated.ratio, coupled.ratio, 1e-9) << mu;
    } else {
      EXPECT_LT(updated.ratio, housner - 0.005) << mu;
      EXPECT_GT(updated.corner_slip, 1e-7) << mu;
    }
  }
}

// The runnable example is the same block: with mu = 1 both schemes give Housner's ratio.
TEST_P(Archetypes, RockingBlockExampleFollowsHousner) {
  ExampleRun run("rocking_block", GetParam());
  TimeStepper& stepper = run.stepper;
  int impacts = 0;
  for (int k = 0; k < 20000 && impacts < 2; ++k) {
    const double before = stepper.v()[2];
    stepper.step();
    const double after = stepper.v()[2];
    if (std::abs(before) > 0.05 && std::abs(after) < 0.8 * std::abs(before)) {
      EXPECT_NEAR(after / before, housnerRatio(RockingBlockParameters{}), 1e-3) << impacts;
      ++impacts;
    }
  }
  EXPECT_EQ(impacts, 2);
}

// V2b from examples/archetypes/block_on_incline.yaml: with mu = 0.2 the block slides at
// g (sin a - mu cos a) (measured over 1000 steps after 10, to 1e-9: constant acceleration
// is exact for the scheme); with mu = 0.5 > tan a it sticks, and over 10^4 steps (10 s) its
// centre moves by less than 1e-12 m.
TEST_P(Archetypes, BlockOnInclineExampleSlidesOrSticks) {
  const double a = 0.4, g = 9.81;
  const Vector3 down(-std::cos(a), -std::sin(a), 0.0);
  for (double mu : {0.2, 0.5}) {
    ExampleRun run("block_on_incline", GetParam(), {"contact.friction=" + std::to_string(mu)});
    TimeStepper& stepper = run.stepper;
    const double h = run.file.run.scheme.h;
    for (int k = 0; k < 10; ++k) stepper.step();
    const double v0 = stepper.v().head<3>().dot(down);
    const Vector3 x0(stepper.q()[0], stepper.q()[1], 0.0);
    const int steps = mu < std::tan(a) ? 1000 : 10000;
    for (int k = 0; k < steps; ++k) stepper.step();
    if (mu < std::tan(a)) {
      const double acceleration = (stepper.v().head<3>().dot(down) - v0) / (steps * h);
      EXPECT_NEAR(acceleration, g * (std::sin(a) - mu * std::cos(a)), 1e-9);
    } else {
      EXPECT_LT((Vector3(stepper.q()[0], stepper.q()[1], 0.0) - x0).norm(), 1e-12);
    }
  }
}

// V7 from examples/archetypes/painleve_rod.yaml, one step at h = 1e-4. Jean-Moreau jams: an
// O(1) impulse (0.3, 0.4) stops A and leaves v+ = (-0.6, 0.3, 1.342) and KE = 0.30 (the
// reference's values as h -> 0; 2e-3 allows for the step's own gravity impulse, g h ~ 1e-3).
// The staggered scheme does not jump: stage 5a's normal impulse is h N0, N0 = m g / W_NN
// (0.625 m g), stage 5b's friction impulse is mu h N0, and GLOBAL mode adds the bilateral
// correction -W_NT mu h N0 / W_NN that holds U_N: in all h N0 (1 + mu 1.2 / 1.6) = 2.125 h N0,
// O(h) (to 1e-3 relative: W is evaluated at the midpoint, which has not turned). The rod keeps
// sliding, losing O(h) speed (2.34 g h = 2.3e-3 m/s).
// With threshold updates the staggered scheme jams as Jean-Moreau does: each round's normal
// correction raises the next round's threshold by the factor mu |W_NT| / W_NN = 1.125, until
// the end sticks, which takes 27 rounds from the frictionless impulse (10 rounds leave the
// first step at 0.015, still sliding). With 40, the first step's impulse and velocity are
// Jean-Moreau's, (0.3, 0.4) and (-0.6, 0.3, 1.342), and kinetic energy does not rise over
// the solve.
TEST(PainleveRod, ThresholdUpdatesJamTheStaggeredScheme) {
  ExampleRun run("painleve_rod", Scheme::CatchingUp, {"scheme.threshold_updates=40"});
  TimeStepper& stepper = run.stepper;
  const StepStats& stats = stepper.step();
  const Vector3 P = stepper.impulses()[0];
  std::printf("Painleve, threshold updates: P = (%.4f, %.4f), v = (%.4f, %.4f, %.4f)\n", P.x(),
              P.y(), stepper.v()[0], stepper.v()[1], stepper.v()[2]);
  EXPECT_NEAR(P.x(), 0.3, 2e-3);
  EXPECT_NEAR(std::abs(P.y()), 0.4, 2e-3);
  EXPECT_LT((stepper.v() - Vector3(-0.6, 0.3, 1.342)).norm(), 2e-3);
  EXPECT_LE(stats.kinetic_solved, stats.kinetic_stage1 * (1.0 + 1e-9));
  EXPECT_LE(stats.kinetic_stage1, stats.kinetic_free * (1.0 + 1e-9));
}

TEST(PainleveRod, ExampleJamsInMoreauJeanAndSlidesInTheStaggeredScheme) {
  for (Scheme scheme : {Scheme::MoreauJean, Scheme::CatchingUp}) {
    ExampleRun run("painleve_rod", scheme);
    TimeStepper& stepper = run.stepper;
    const double h = run.file.run.scheme.h;
    stepper.step();
    ASSERT_EQ(stepper.impulses().size(), 1u);
    const Vector3 P = stepper.impulses()[0];
    const VectorX& v = stepper.v();
    if (scheme == Scheme::MoreauJean) {
      EXPECT_NEAR(P.x(), 0.3, 2e-3);
      EXPECT_NEAR(std::abs(P.y()), 0.4, 2e-3);
      EXPECT_LT((v - Vector3(-0.6, 0.3, 1.342)).norm(), 2e-3);
      EXPECT_NEAR(stepper.stats().kinetic, 0.30, 2e-3);
    } else {
      const double expected = 2.125 * h * 0.625 * 9.81;
      EXPECT_NEAR(P.x(), expected, 1e-3 * expected);
      EXPECT_NEAR(std::abs(P.y()), 1.5 * h * 0.625 * 9.81, 1e-3 * expected);
      EXPECT_NEAR(v[0], -1.0, 2.5 * 9.81 * h);
      EXPECT_LE(stepper.stats().work_tangent, 0.0);
      EXPECT_NEAR(stepper.stats().kinetic, 0.5, 2e-3);
    }
  }
}

// The URDF case, examples/archetypes/arm_on_table.yaml: a passive 6-dof arm read from URDF
// falls onto a table; joints 2 and 3 reach their limits and the arm hits the table.
// - Jean-Moreau with the POS law treats each limit as a position constraint of the coupled
//   solve: no joint passes its limit by more than 1e-9 rad (measured 5e-11; before the limit
//   rows saw the free velocity, a joint accelerated into its limit within a step passed it
//   by 5e-6 rad).
// - The staggered scheme with its convex stage solvers keeps them to 1e-7 rad (measured
//   6.6e-9): stage 5b guards the rows 5a left open (OpenContacts::Unilateral) and solves them
//   to the tolerance with the held ones.
// - Energy: the run ends with less than it started (e = 0). Per step it may rise by the
//   smooth integrator's own O(h^2) error on the arm (2.4e-4 J on 50 J with VEL), so no
//   per-step bound is asserted.
TEST_P(Archetypes, UrdfArmOnTableRespectsItsLimits) {
  ExampleRun run("arm_on_table", GetParam());
  const SceneFile& file = run.file;
  const Model& model = run.scene.model;
  TimeStepper& stepper = run.stepper;
  ASSERT_EQ(model.limits.size(), 12u);
  const double start = stepper.energy();
  double worst = 0.0;
  std::vector<int> active(model.limits.size(), 0);
  int table_contacts = 0;
  const int steps = static_cast<int>(std::lround(file.run.t_end / file.run.scheme.h));
  for (int k = 0; k < steps; ++k) {
    const StepStats& s = stepper.step();
    for (std::size_t i = 0; i < model.limits.size(); ++i) {
      const JointLimit& limit = model.limits[i];
      worst = std::max(worst, -limit.side * (stepper.q()[limit.q_index] - limit.bound));
      if (stepper.limitImpulses()[i] > 0.0) ++active[i];
    }
    table_contacts = std::max(table_contacts, s.active);
  }
  std::printf("URDF arm (%s): worst limit violation %.3g rad, energy %.4g -> %.4g J\n",
              enumName(GetParam()), worst, start, stepper.energy());
  int limits_hit = 0;
  for (int count : active) limits_hit += count > 0 ? 1 : 0;
  EXPECT_GE(limits_hit, 2);
  EXPECT_GE(table_contacts, 1);
  EXPECT_LT(stepper.energy(), start);
  EXPECT_LT(worst, GetParam() == Scheme::MoreauJean ? 1e-9 : 1e-7);
}

// V3 from examples/archetypes/ramp_force.yaml: under F = k t the block sticks exactly (no
// creep: stick is a solved state, not a slow slide) until the first step whose midpoint
// force exceeds mu m g, step ceil(t* / h + 1/2) (the reference's ceil(t* / h) +- 1), and then
// slides with acceleration (k t_m - mu m g) / m in every step, exact for the discrete scheme
// (constant forces within a step), so to round-off. The first two steps are left out: the
// block starts exactly tangent, so the first step is a free step (see V4 above).
TEST_P(Archetypes, RampForceExampleSticksThenSlides) {
  ExampleRun run("ramp_force", GetParam());
  TimeStepper& stepper = run.stepper;
  const double h = run.file.run.scheme.h, k = 12.0, mu = 0.5, m = 1.0, g = 9.81;
  const double t_star = mu * m * g / k;
  const long expected = static_cast<long>(std::ceil(t_star / h + 0.5));
  stepper.step();
  stepper.step();
  long first_sliding = 0;
  double worst = 0.0;
  while (stepper.time() < run.file.run.t_end - 0.5 * h) {
    const double before = stepper.v()[0];
    const double t_m = stepper.time() + 0.5 * h;
    stepper.step();
    if (first_sliding == 0) {
      if (std::abs(stepper.v()[0]) > 1e-12)
        first_sliding = stepper.stats().step;
      else
        continue;
    }
    // from the step after the first sliding one, whose start velocity is still zero
    if (stepper.stats().step > first_sliding)
      worst = std::max(worst, std::abs((stepper.v()[0] - before) / h - (k * t_m - mu * m * g) / m));
  }
  EXPECT_EQ(first_sliding, expected);
  EXPECT_LT(worst, 1e-9);
  EXPECT_GT(stepper.v()[0], 0.0);
}

// V3's convergence: x(t_end) against k (t - t*)^3 / (6 m), h = 1e-3 halved four times. The
// error is second order, not first: the acceleration is continuous at the onset (it starts
// from zero), so quantizing the onset to a step costs O(h^2) in position. Measured local
// orders 2.3, 1.0, 2.0, 2.0 (where t* falls in the step changes with h), fit 1.76.
TEST_P(Archetypes, RampForceConvergesAtLeastAtFirstOrder) {
  std::vector<double> steps;
  for (int k = 0; k < 5; ++k) steps.push_back(1e-3 / std::pow(2.0, k));
  const SceneFile file = loadSceneFile(SWEEP_SOURCE_DIR "/examples/archetypes/ramp_force.yaml");
  const std::vector<ConvergencePoint> points =
      rampForceConvergence(file, GetParam(), steps, 12.0, 0.5, 1.0);
  EXPECT_GT(fittedOrder(points), 1.5);
  EXPECT_LT(points.back().error, points.front().error / 50.0);
  EXPECT_LT(points.front().error, 1e-6);  // m, at h = 1e-3 after 0.59 s of sliding
}

// V5's convergence: the ratio at the first corner impact against Housner's, h = 1e-3
// halved six times. First order: gravity acts through the impact step. Measured fit 0.96;
// the local orders scatter (-0.0 to 2.0) with where the impact falls inside the step.
TEST_P(Archetypes, RockingBlockRatioConvergesAtFirstOrder) {
  std::vector<double> steps;
  for (int k = 0; k < 7; ++k) steps.push_back(1e-3 / std::pow(2.0, k));
  const std::vector<ConvergencePoint> points =
      rockingBlockConvergence(RockingBlockParameters{}, GetParam(), steps);
  EXPECT_GT(fittedOrder(points), 0.7);
  EXPECT_LT(fittedOrder(points), 1.3);
  EXPECT_LT(points.back().error, points.front().error / 20.0);
}

// V7's convergence, Jean-Moreau: the jam impulse tends to (0.3, 0.4) at first order (the
// gravity impulse of the step, m g h, enters it linearly). Measured: exactly 1.000 per
// halving, 8.8e-3 at h = 1e-3.
TEST(PainleveRod, JamImpulseConvergesAtFirstOrder) {
  std::vector<double> steps;
  for (int k = 0; k < 5; ++k) steps.push_back(1e-3 / std::pow(2.0, k));
  const SceneFile file = loadSceneFile(SWEEP_SOURCE_DIR "/examples/archetypes/painleve_rod.yaml");
  const std::vector<ConvergencePoint> points = painleveJamConvergence(file, steps);
  for (std::size_t k = 1; k < points.size(); ++k) EXPECT_NEAR(points[k].order, 1.0, 0.05) << k;
  EXPECT_LT(points.front().error, 1e-2);
}

// V10's reference (CVODE with root finding, exact impact law, persistent contacts): over
// 5 s the lower bob (e = 0) hits three times and stops dead against the wall, and gravity
// then pulls it away rather than holding it (no contact phase); the upper bob (e = 1)
// rebounds elastically seven times. Between impacts the energy is that of a conservative
// system (CVODE at rtol 1e-12), and the plastic impacts only lose energy.
TEST(WallPendulum, ReferenceImpactsAndEnergy) {
  const WallPendulumReference reference =
      wallPendulumReference(WallPendulumParameters{}, 5.0, 0.01);
  int upper = 0, lower = 0;
  for (const Impact& impact : reference.impacts) {
    EXPECT_LT(impact.normal_velocity_before, 0.0);
    if (impact.constraint == 0) {
      ++upper;
      EXPECT_NEAR(impact.normal_velocity_after, -impact.normal_velocity_before, 1e-12);
    } else {
      ++lower;
      EXPECT_NEAR(impact.normal_velocity_after, 0.0, 1e-12);
    }
  }
  EXPECT_EQ(lower, 3);
  EXPECT_EQ(upper, 7);
  EXPECT_TRUE(reference.phases.empty());
  EXPECT_NEAR(reference.impacts.front().t, 0.639878, 1e-6);  // the lower bob, first
  EXPECT_LT(reference.energy_end, reference.energy_start - 0.2);
}

// The V10 example loads the pendulum from URDF (examples/archetypes/double_pendulum.urdf,
// per-link materials for the two restitutions); wallPendulum() codes it by hand. Same
// masses, inertias, shapes and laws, so the two runs agree to round-off through the first
// impacts (t = 0.64 and 0.69 s).
TEST_P(Archetypes, WallPendulumFromUrdfEqualsTheCodedModel) {
  ExampleRun urdf("double_pendulum_wall", GetParam());
  const Scene coded = wallPendulum(WallPendulumParameters{});
  TimeStepper stepper(coded.model, coded.cmodel, urdf.file.run.scheme);
  stepper.reset(0.0, coded.q0, coded.v0);
  ASSERT_LT((urdf.scene.q0 - coded.q0).norm(), 1e-15);
  int impacts = 0;
  for (int k = 0; k < 2000; ++k) {
    urdf.stepper.step();
    stepper.step();
    impacts += stepper.stats().active > 0 && urdf.stepper.stats().active > 0;
    ASSERT_LT((urdf.stepper.q() - stepper.q()).norm(), 1e-12) << "step " << k;
    ASSERT_LT((urdf.stepper.v() - stepper.v()).norm(), 1e-12) << "step " << k;
  }
  EXPECT_GT(impacts, 0);
}

// Both schemes converge to the V10 reference at first order: the RMS joint-angle error over
// 5 s, sampled every 0.01 s, for h = 5e-4 (the reference's step) halved four times. Measured
// orders 0.7 to 1.4 per halving, fit 1.01; the schemes coincide here (frictionless, so the
// staggered scheme's normal stage is the whole solve and equals Jean-Moreau's).
TEST_P(Archetypes, WallPendulumFirstOrderAgainstTheEventDrivenReference) {
  std::vector<double> steps;
  for (int k = 0; k < 5; ++k) steps.push_back(5e-4 / std::pow(2.0, k));
  const std::vector<ConvergencePoint> points =
      wallPendulumConvergence(WallPendulumParameters{}, GetParam(), steps, 5.0, 0.01);
  const double order = fittedOrder(points);
  EXPECT_GT(order, 0.7);
  EXPECT_LT(order, 1.3);
  EXPECT_LT(points.back().error, points.front().error / 8.0);  // 16 at exactly first order
  EXPECT_LT(points.front().error, 2e-3);                       // rad, at the reference's h = 5e-4
}

// V10's energy in the time-stepping scheme: between impacts it drifts at first order in h
// (its largest rise halves with h: docs/validation.md), and the impacts only remove energy
// (e <= 1 under Moreau's law). Over 5 s at h = 5e-4 the energy never exceeds its start by
// more than 1e-5 J (measured 7.4e-7 J). The plastic impacts remove 0.23 J in all; where
// they fall is O(h) off, and so is what they remove: the end energy is within 2e-3 J of the
// reference's (measured 7e-5 J).
TEST_P(Archetypes, WallPendulumEnergyNeverGrows) {
  ExampleRun run("double_pendulum_wall", GetParam());
  const double start = run.stepper.energy();
  double highest = start;
  for (int k = 0; k < 10000; ++k) {
    run.stepper.step();
    highest = std::max(highest, run.stepper.energy());
  }
  const WallPendulumReference reference =
      wallPendulumReference(WallPendulumParameters{}, 5.0, 0.01);
  std::printf("V10 energy: start %.9f, highest %+.3e above it, end %.6f (reference %.6f)\n", start,
              highest - start, run.stepper.energy(), reference.energy_end);
  EXPECT_LT(highest - start, 1e-5);
  EXPECT_NEAR(run.stepper.energy(), reference.energy_end, 2e-3);
}

// V11, the slider-crank with a clearance in its slider's guide, over the reference's 0.2 s at
// its h = 1e-5 and at h / 2 (measured: 5 400 to 11 500 steps with contacts, crank angle
// 18.04 and 18.06 rad at the end, energy 7.4955 J down to 6.923 J and 6.959 J).
// - The energy never rises above its start (e_N = 0.4 and mu = 0.01 only dissipate; the
//   midpoint rule's own O(h^2) oscillation is 4e-5 J per step at most, and the contacts take
//   more than that from the start).
// - The energy lost equals the work of the contact impulses, sum P . (U_k + U_{k+1}) / 2,
//   up to O(h): the identity of reference 5.3 is exact for a constant M, and M(q) turns
//   with the crank. The mismatch must halve with h (measured 0.074 J, then 0.037 J).
// - Halving h moves the crank's final angle by O(h) (measured 0.020 rad); across the two
//   schemes it moves by far less (1e-5 rad at h = 1e-5: friction is light, so the
//   staggered scheme's friction stage changes little).
TEST_P(Archetypes, SliderCrankWithClearanceBalancesEnergyAndConverges) {
  const SliderCrankParameters parameters;
  const SliderCrankRun coarse = sliderCrankRun(parameters, GetParam(), 1e-5, 0.2);
  const SliderCrankRun fine = sliderCrankRun(parameters, GetParam(), 5e-6, 0.2);
  for (const SliderCrankRun* run : {&coarse, &fine}) {
    EXPECT_LE(run->energy_highest, run->energy_start);
    EXPECT_GT(run->contact_steps, 1000);
    EXPECT_LT(run->penetration_max, 2e-5);  // VEL: about v h / 2 at impacts
  }
  const double mismatch_coarse =
      std::abs(coarse.energy_end - coarse.energy_start - coarse.contact_work);
  const double mismatch_fine = std::abs(fine.energy_end - fine.energy_start - fine.contact_work);
  std::printf(
      "V11: energy %.6f -> %.6f (h) / %.6f (h/2); work mismatch %.4f / %.4f J; "
      "crank %.6f / %.6f rad; %ld / %ld steps with contacts\n",
      coarse.energy_start, coarse.energy_end, fine.energy_end, mismatch_coarse, mismatch_fine,
      coarse.theta[0], fine.theta[0], static_cast<long>(coarse.contact_steps),
      static_cast<long>(fine.contact_steps));
  EXPECT_LT(mismatch_fine, 0.6 * mismatch_coarse);
  EXPECT_LT(mismatch_coarse, 0.15 * (coarse.energy_start - coarse.energy_end));
  EXPECT_LT(std::abs(coarse.theta[0] - fine.theta[0]), 0.05);
  if (GetParam() == Scheme::CatchingUp) {
    const SliderCrankRun jean_moreau = sliderCrankRun(parameters, Scheme::MoreauJean, 1e-5, 0.2);
    EXPECT_LT(std::abs(coarse.theta[0] - jean_moreau.theta[0]), 1e-3);
  }
}

// The V11 example loads the mechanism from URDF in 3D (examples/archetypes/slider_crank.yaml):
// a box slider whose eight corners make four pairs of coincident contacts with the guide
// planes. Jean-Moreau's velocities are unique even where such duplicate rows split the
// impulse, so it must follow the 2D model coded by hand (one contact per corner): over the
// first 0.05 s (1 914 steps with contacts) the joint angles agree to 1e-6 rad and the
// energies to 1e-6 J (measured 9e-11 rad, 3e-10 J).
TEST(SliderCrank, UrdfExampleFollowsThe2DModel) {
  ExampleRun urdf("slider_crank", Scheme::MoreauJean);
  Scene coded = sliderCrank(SliderCrankParameters{});
  // the same margin floor, so that VEL keeps the same gaps closed in both (touchingGap and
  // heldGap scale with it; the URDF slider box is 0.01 m thick, the 2D slider 0.05 m high)
  coded.cmodel.margin_floor = urdf.scene.cmodel.margin_floor;
  TimeStepper stepper(coded.model, coded.cmodel, urdf.file.run.scheme);
  stepper.reset(0.0, coded.q0, coded.v0);
  ASSERT_LT((urdf.scene.v0 - coded.v0).norm(), 1e-12);
  long contact_steps = 0;
  for (int k = 0; k < 5000; ++k) {
    urdf.stepper.step();
    stepper.step();
    contact_steps += stepper.stats().active > 0;
  }
  std::printf("V11 URDF vs 2D: %ld contact steps, angle gap %.3e rad, energy gap %.3e J\n",
              contact_steps, (urdf.stepper.q() - stepper.q()).norm(),
              std::abs(urdf.stepper.energy() - stepper.energy()));
  EXPECT_GT(contact_steps, 20);
  EXPECT_LT((urdf.stepper.q() - stepper.q()).norm(), 1e-6);
  EXPECT_LT(std::abs(urdf.stepper.energy() - stepper.energy()), 1e-6);
}

// V9, the woodpecker toy, Jean-Moreau at the Siconos step h = 2e-5 over 1 s, and at h / 2:
// - a periodic descent: one beak impact per cycle, 8 in 1 s (the first at 0.083 s), the
//   cycles after the first of equal length to 1 % (measured 0.1309 s +- 0.0001) and the
//   sleeve lower by the same step each cycle to 2 % (measured 14.6 mm);
// - halving h moves the first two beak impacts by less than 1e-4 s (measured 1e-5 s); the
//   period itself moves by O(h), 4e-5 s, and the shift adds up over the cycles, so after
//   the first two the cycles are compared instead: period within 0.1 %, drop within 1 %;
// - the energy (kinetic, gravity, spring) never rises over a step by more than 1e-9 J
//   (measured 1e-11 J: the midpoint rule's O(h^2)), and what it loses is the work of the
//   contact impulses to 1e-4 of the loss (measured 2e-6: the contacts are points on fixed
//   faces, so reference 5.3's identity is nearly exact here).
TEST(Woodpecker, MoreauJeanDescendsPeriodically) {
  const WoodpeckerParameters parameters;
  const WoodpeckerRun run = woodpeckerRun(parameters, Scheme::MoreauJean, 2e-5, 1.0);
  const WoodpeckerRun fine = woodpeckerRun(parameters, Scheme::MoreauJean, 1e-5, 1.0);
  ASSERT_EQ(run.beak_times.size(), 8u);
  ASSERT_EQ(fine.beak_times.size(), 8u);
  const double period = (run.beak_times[7] - run.beak_times[1]) / 6.0;
  const double drop = (run.beak_heights[1] - run.beak_heights[7]) / 6.0;
  for (std::size_t k = 1; k < 7; ++k) {
    EXPECT_NEAR(run.beak_times[k + 1] - run.beak_times[k], period, 0.01 * period) << k;
    EXPECT_NEAR(run.beak_heights[k] - run.beak_heights[k + 1], drop, 0.02 * drop) << k;
  }
  for (std::size_t k = 0; k < 2; ++k) EXPECT_NEAR(run.beak_times[k], fine.beak_times[k], 1e-4) << k;
  const double fine_period = (fine.beak_times[7] - fine.beak_times[1]) / 6.0;
  const double fine_drop = (fine.beak_heights[1] - fine.beak_heights[7]) / 6.0;
  EXPECT_NEAR(fine_period, period, 1e-3 * period);
  EXPECT_NEAR(fine_drop, drop, 1e-2 * drop);
  std::printf(
      "V9: period %.5f s (h / 2: %.5f), drop per cycle %.3f mm (%.3f), y(1 s) %.5f m; "
      "energy %.4e -> %.4e J\n",
      period, fine_period, 1e3 * drop, 1e3 * fine_drop, run.y_end, run.energy_start,
      run.energy_end);
  EXPECT_LT(run.largest_step_rise, 1e-9);
  const double lost = run.energy_start - run.energy_end;
  EXPECT_GT(lost, 0.0);
  EXPECT_LT(std::abs(run.contact_work + lost), 1e-4 * lost);
}

// The staggered scheme on V9: its friction stage is bounded by thresholds frozen from the
// frictionless normal stage, so the sleeve cannot jam by friction (self-locking needs the
// normal force that friction itself produces; reference 4.3, and V7 above): the toy slides
// down the pole, 4.2 m in 1 s, with 4 beak impacts. Its energy account still closes, and it
// never gains energy.
TEST(Woodpecker, StaggeredSchemeCannotJamButKeepsItsEnergyAccount) {
  const WoodpeckerRun run = woodpeckerRun(WoodpeckerParameters{}, Scheme::CatchingUp, 2e-5, 1.0);
  std::printf("V9 staggered: y(1 s) %.3f m, %zu beak impacts\n", run.y_end, run.beak_times.size());
  EXPECT_LT(run.largest_step_rise, 1e-9);
  const double lost = run.energy_start - run.energy_end;
  EXPECT_LT(std::abs(run.contact_work + lost), 1e-4 * lost);
  EXPECT_LT(run.y_end, -1.0);  // the characterization above: a slide, not a descent by pecks
}

// With threshold updates (ten rounds of stage 5b, each taking its thresholds from the last
// round's total normal impulse) the staggered scheme jams the sleeve between pecks, as
// Jean-Moreau does: a descent by pecks, not a slide. The energy account still closes, and
// no step gains energy.
TEST(Woodpecker, StaggeredSchemeWithThresholdUpdatesJams) {
  const WoodpeckerRun run =
      woodpeckerRun(WoodpeckerParameters{}, Scheme::CatchingUp, 2e-5, 1.0, 10);
  const WoodpeckerRun frozen =
      woodpeckerRun(WoodpeckerParameters{}, Scheme::CatchingUp, 2e-5, 1.0, 0);
  std::printf(
      "V9 staggered, threshold updates: y(1 s) %.4f m, %zu beak impacts, period %.4f s "
      "(frozen thresholds: y %.3f m, %zu impacts)\n",
      run.y_end, run.beak_times.size(),
      run.beak_times.size() > 2 ? (run.beak_times.back() - run.beak_times[1]) /
                                      static_cast<double>(run.beak_times.size() - 2)
                                : 0.0,
      frozen.y_end, frozen.beak_times.size());
  EXPECT_LT(run.largest_step_rise, 1e-9);
  const double lost = run.energy_start - run.energy_end;
  EXPECT_LT(std::abs(run.contact_work + lost), 1e-4 * lost);
  EXPECT_GT(run.y_end, -0.3);
  EXPECT_LT(frozen.y_end, -1.0);
  EXPECT_GE(run.beak_times.size(), 6u);
}

// The V9 example loads the toy from URDF in 3D (points as 10 um spheres, the spring as a
// joint spring of the scene file); Jean-Moreau must follow the 2D model coded by hand to
// round-off over its first cycle and a half (0.2 s).
TEST(Woodpecker, UrdfExampleFollowsThe2DModel) {
  ExampleRun urdf("woodpecker", Scheme::MoreauJean);
  const Scene coded = woodpecker(WoodpeckerParameters{});
  TimeStepper stepper(coded.model, coded.cmodel, urdf.file.run.scheme, coded.forces);
  stepper.reset(0.0, coded.q0, coded.v0);
  ASSERT_LT((urdf.scene.q0 - coded.q0).norm(), 1e-15);
  for (int k = 0; k < 10000; ++k) {
    urdf.stepper.step();
    stepper.step();
  }
  std::printf("V9 URDF vs 2D: state gap %.3e\n", (urdf.stepper.q() - stepper.q()).norm());
  EXPECT_LT((urdf.stepper.q() - stepper.q()).norm(), 1e-9);
  EXPECT_LT((urdf.stepper.v() - stepper.v()).norm(), 1e-7);
}

INSTANTIATE_TEST_SUITE_P(Schemes, Archetypes,
                         ::testing::Values(Scheme::MoreauJean, Scheme::CatchingUp),
                         [](const ::testing::TestParamInfo<Scheme>& scheme) {
                           return std::string(scheme.param == Scheme::MoreauJean ? "MoreauJean"
                                                                                 : "CatchingUp");
                         });

}  // namespace
}  // namespace sweep
