// The scene of the user guide (docs/guide.md, examples/tutorial/hopper.yaml) does what the
// guide says: with either scheme the 60 beads roll off the ramp and end in the box, slower
// than 0.2 m/s, a seventh of their landing speed (measured: 0.14 and 0.11 m/s; with no rolling
// resistance a disk on the floor keeps rolling), with less than a tenth of the energy left
// (measured 0.067 and 0.060); the staggered scheme converged on every step.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>

#include "apps/sweep/scene_file.hpp"

namespace sweep {
namespace {

class Tutorial : public ::testing::TestWithParam<Scheme> {};

TEST_P(Tutorial, BeadsEndInTheBox) {
  SceneFile file = loadSceneFile(SWEEP_SOURCE_DIR "/examples/tutorial/hopper.yaml");
  file.run.scheme.scheme = GetParam();
  const Scene scene = buildSceneFile(file);
  TimeStepper stepper(scene.model, scene.cmodel, file.run.scheme, scene.forces);
  stepper.reset(0.0, scene.q0, scene.v0);
  const double start = stepper.energy();
  int unconverged = 0;
  for (int k = 0; k < 5000; ++k)
    unconverged += stepper.step().status == SolverStatus::Converged ? 0 : 1;
  const VectorX& q = stepper.q();
  ASSERT_EQ(q.size(), 180);
  for (int b = 0; b < 60; ++b) {
    const double x = q[3 * b], y = q[3 * b + 1];
    EXPECT_GT(x, -0.05) << "bead " << b;
    EXPECT_LT(x, 0.05) << "bead " << b;
    EXPECT_GT(y, 1.5e-3) << "bead " << b << " below the floor";
    EXPECT_LT(y, 0.03) << "bead " << b << " not in the box";
  }
  double fastest = 0.0;
  for (int b = 0; b < 60; ++b) fastest = std::max(fastest, stepper.v().segment<2>(3 * b).norm());
  std::printf("%s: fastest bead %.3g m/s, energy %.3g of the start\n", enumName(GetParam()),
              fastest, stepper.energy() / start);
  EXPECT_LT(fastest, 0.2);
  EXPECT_LT(stepper.energy(), 0.1 * start);
  // Jean-Moreau's sweeps reach their cap on some steps of the resting pile (docs/guide.md)
  if (GetParam() == Scheme::CatchingUp) {
    EXPECT_EQ(unconverged, 0);
  }
}

INSTANTIATE_TEST_SUITE_P(BothSchemes, Tutorial,
                         ::testing::Values(Scheme::MoreauJean, Scheme::CatchingUp),
                         [](const auto& test) {
                           return test.param == Scheme::MoreauJean ? "MoreauJean" : "CatchingUp";
                         });

}  // namespace
}  // namespace sweep
