// Both schemes on a pile of 100 frictional disks collapsing in a box: finite, bounded, the
// discrete energy identity at every step, and for the catching-up scheme no energy from
// friction on converged steps (reference 4.4).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "integrators/time_stepper.hpp"
#include "models/granular.hpp"
#include "solver_fixtures.hpp"

namespace sweep {
namespace {

class GranularPile : public ::testing::TestWithParam<Scheme> {};

TEST_P(GranularPile, SettlesWithoutBlowUp) {
  GranularBoxParameters parameters;
  parameters.count = 100;
  const Scene scene = granularBox(parameters);
  SchemeSettings settings;
  settings.scheme = GetParam();
  settings.h = 2e-4;
  TimeStepper stepper(scene.model, scene.cmodel, settings);
  stepper.reset(0.0, scene.q0, scene.v0);
  const double start_energy = stepper.energy();
  double energy = start_energy;
  int cap_hits = 0;
  double peak = 0.0;
  int kane_steps = 0;  // steps with positive tangential contact work
  for (int k = 0; k < 800; ++k) {
    const StepStats& s = stepper.step();
    ASSERT_TRUE(stepper.v().allFinite()) << "step " << k;
    ASSERT_NE(s.status, SolverStatus::Failed) << "step " << k;
    cap_hits += s.cap_hit ? 1 : 0;
    const double next = s.kinetic + s.potential;
    // E(k+1) - E(k) = contact work, exactly for constant M and gravity
    EXPECT_NEAR(next - energy, s.work_normal + s.work_tangent, 1e-9 * std::abs(start_energy))
        << "step " << k;
    if (GetParam() == Scheme::CatchingUp && !s.cap_hit) {
      // reference 4.4, e = 0 and VEL: KE(v2) <= KE(v1) <= KE(v_free); the normal stage is a
      // projection, the friction stage a minimization over a set containing no friction.
      // Slack: what the 1e-6 tolerance leaves of the step's kinetic energy.
      const double slack = 1e-5 * s.kinetic_free + 1e-15;
      EXPECT_LE(s.kinetic_stage1, s.kinetic_free + slack) << "step " << k;
      EXPECT_LE(s.kinetic_solved, s.kinetic_stage1 + slack) << "step " << k;
    }
    kane_steps += s.work_tangent > 0.0 ? 1 : 0;
    peak = std::max(peak, s.penetration_max);
    energy = next;
  }
  // the pile has fallen: energy went down
  EXPECT_LT(energy, start_energy);
  // VEL leaves the penetration of the impact step, (h/2) |U_N|, plus O(h^2 g) (reference
  // 2.7); grains land at most at the free-fall speed from the highest lattice row
  double top = 0.0;
  for (int i = 0; i < scene.model.nv / 3; ++i) top = std::max(top, scene.q0[3 * i + 1]);
  const double fastest = std::sqrt(2.0 * parameters.gravity * top);
  EXPECT_LT(peak, 0.5 * settings.h * fastest + 10.0 * settings.h * settings.h * parameters.gravity);
  RecordProperty("cap_hits", cap_hits);
  std::printf("%s: peak penetration %.3g m, cap hits %d, steps with tangential work > 0: %d\n",
              enumName(GetParam()), peak, cap_hits, kane_steps);
}

// Threshold updates keep the staggered scheme's energy property: every round of stage 5b
// starts from v1 and minimizes the kinetic energy over a set of friction impulses that holds
// zero, so KE(v2) <= KE(v1) whatever the thresholds. Three rounds on the collapsing pile.
TEST(GranularPileThresholdUpdates, NoEnergyFromFriction) {
  GranularBoxParameters parameters;
  parameters.count = 100;
  const Scene scene = granularBox(parameters);
  SchemeSettings settings;
  settings.scheme = Scheme::CatchingUp;
  settings.h = 2e-4;
  settings.friction.threshold_updates = 3;
  TimeStepper stepper(scene.model, scene.cmodel, settings);
  stepper.reset(0.0, scene.q0, scene.v0);
  int converged = 0, raised = 0;
  for (int k = 0; k < 800; ++k) {
    const StepStats& s = stepper.step();
    ASSERT_TRUE(stepper.v().allFinite()) << "step " << k;
    if (s.cap_hit) continue;
    ++converged;
    const double slack = 1e-5 * s.kinetic_free + 1e-15;
    EXPECT_LE(s.kinetic_stage1, s.kinetic_free + slack) << "step " << k;
    EXPECT_LE(s.kinetic_solved, s.kinetic_stage1 + slack) << "step " << k;
    raised += s.iterations_stage2 > 0 ? 1 : 0;
  }
  EXPECT_GT(converged, 700);
  EXPECT_GT(raised, 100);
}

INSTANTIATE_TEST_SUITE_P(Schemes, GranularPile,
                         ::testing::Values(Scheme::MoreauJean, Scheme::CatchingUp),
                         test::schemeTestName);

}  // namespace
}  // namespace sweep
