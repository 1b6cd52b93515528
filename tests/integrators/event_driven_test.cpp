// The event-driven reference's own machinery: the small complementarity solver behind its
// impacts and contact closings, and persistent contacts that close, hold and open.
#include "integrators/event_driven.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "framework/energy.hpp"
#include "framework/kinematics.hpp"
#include "models/kinematic_trees.hpp"

namespace sweep {
namespace {

void expectComplementary(const MatrixX& G, const VectorX& b, const VectorX& x) {
  const VectorX w = G * x + b;
  for (Eigen::Index i = 0; i < b.size(); ++i) {
    EXPECT_GE(x[i], 0.0) << i;
    EXPECT_GE(w[i], -1e-12) << i;
    EXPECT_NEAR(x[i] * w[i], 0.0, 1e-12) << i;
  }
}

TEST(SmallLcp, SolvesMixedActiveSets) {
  MatrixX G(2, 2);
  G << 2.0, 1.0, 1.0, 2.0;
  VectorX b(2), x;
  b << -3.0, 1.0;  // x = (1.5, 0): w = (0, 2.5)
  ASSERT_TRUE(solveSmallLcp(G, b, x));
  EXPECT_NEAR(x[0], 1.5, 1e-14);
  EXPECT_EQ(x[1], 0.0);
  expectComplementary(G, b, x);
  b << -3.0, -3.0;  // both active: x = (1, 1)
  ASSERT_TRUE(solveSmallLcp(G, b, x));
  EXPECT_NEAR(x[0], 1.0, 1e-14);
  EXPECT_NEAR(x[1], 1.0, 1e-14);
}

// Two copies of one contact (a singular Delassus matrix): the impulse is not unique; the
// solver must still return one that satisfies the law, the sparsest.
TEST(SmallLcp, RedundantRowsHaveASolution) {
  MatrixX G(2, 2);
  G << 1.0, 1.0, 1.0, 1.0;
  VectorX b(2), x;
  b << -2.0, -2.0;
  ASSERT_TRUE(solveSmallLcp(G, b, x));
  EXPECT_NEAR(x.sum(), 2.0, 1e-14);
  EXPECT_EQ((x.array() > 0.0).count(), 1);
  expectComplementary(G, b, x);
}

// A double pendulum whose upper link is stopped by a plastic stop (e = 0) at th1 = 0.05 while
// gravity pushes it there: the contact closes, holds while the lower link swings, and opens
// when the lower link's swing pulls the upper one away; then it hits and closes again.
// While closed, the stop does no work (frictionless, fixed): the energy stays constant to
// the CVODE tolerance, and the gap stays at zero.
TEST(EventDrivenReference, PersistentContactClosesHoldsAndOpens) {
  DoublePendulumParameters parameters;
  parameters.tip_inertia = 1e-4;
  const Model model = doublePendulum(parameters);
  UnilateralConstraint stop;
  const double s0 = std::sin(0.05);
  stop.gap = [s0](const VectorX& q) { return std::sin(q[0]) - s0; };
  stop.normal = [](const VectorX& q) { return VectorX(Eigen::Vector2d(std::cos(q[0]), 0.0)); };
  stop.restitution = 0.0;  // no curvature given: the central difference is exercised
  EventDrivenReference reference(model, {stop});
  const VectorX q0 = Eigen::Vector2d(0.3, 0.4), v0 = VectorX::Zero(2);
  reference.reset(0.0, q0, v0);
  Data data(model);
  auto energy = [&] {
    forwardKinematics(model, data, reference.q(), reference.v());
    return kineticEnergy(model, data) + potentialEnergy(model, data);
  };
  double previous_energy = energy();
  std::size_t previous_impacts = 0;
  int closed_samples = 0;
  for (int j = 1; j <= 200; ++j) {
    reference.advanceTo(0.025 * j);
    const double e = energy();
    if (reference.impacts().size() == previous_impacts)
      EXPECT_NEAR(e, previous_energy, 1e-8) << "t = " << reference.time();
    else
      EXPECT_LT(e, previous_energy);  // a plastic impact loses energy
    previous_energy = e;
    previous_impacts = reference.impacts().size();
    if (reference.closed(0)) {
      ++closed_samples;
      EXPECT_NEAR(stop.gap(reference.q()), 0.0, 1e-9);
      EXPECT_NEAR(stop.normal(reference.q()).dot(reference.v()), 0.0, 1e-9);
    }
    EXPECT_GT(stop.gap(reference.q()), -1e-9);
  }
  const std::vector<ContactPhase>& phases = reference.phases();
  ASSERT_GE(phases.size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_TRUE(std::isfinite(phases[k].t_open)) << k;
    EXPECT_GT(phases[k].t_open - phases[k].t_close, 0.5) << k;  // held for a while
  }
  EXPECT_GT(closed_samples, 40);
  for (const Impact& impact : reference.impacts())
    EXPECT_NEAR(impact.normal_velocity_after, 0.0, 1e-14);  // e = 0, up to round-off
}

}  // namespace
}  // namespace sweep
