#include "integrators/smooth_reference.hpp"

#include <gtest/gtest.h>

#include "framework/energy.hpp"
#include "framework/error.hpp"
#include "framework/kinematics.hpp"
#include "models/kinematic_trees.hpp"
#include "models/rigid_bodies.hpp"
#include "test_models.hpp"

namespace sweep {
namespace {

double totalEnergy(const Model& model, Data& data, const VectorX& q, const VectorX& v) {
  forwardKinematics(model, data, q, v);
  return kineticEnergy(model, data) + potentialEnergy(model, data);
}

TEST(SmoothReference, ConservativeDoublePendulumKeepsEnergy) {
  const Model model = doublePendulum();
  Data data(model);
  SmoothReferenceIntegrator cvode(model);
  VectorX q0(2), v0(2);
  q0 << 1.2, -0.4;
  v0 << 0.0, 0.5;
  cvode.reset(0.0, q0, v0);
  const double e0 = totalEnergy(model, data, q0, v0);
  double worst = 0.0;
  for (int k = 1; k <= 100; ++k) {
    cvode.advanceTo(0.1 * k);
    worst = std::max(worst, std::abs(totalEnergy(model, data, cvode.q(), cvode.v()) - e0));
  }
  EXPECT_DOUBLE_EQ(cvode.time(), 10.0);
  EXPECT_LT(worst / std::abs(e0), 1e-8);
  // it moved: the pendulum swung through a large angle
  EXPECT_GT(std::abs(cvode.q()[0] - q0[0]) + std::abs(cvode.q()[1] - q0[1]), 0.1);
}

TEST(SmoothReference, TorqueFreeTumblingBoxKeepsEnergyAndAngularMomentum) {
  ModelBuilder b("box");
  b.setGravity(Vector3::Zero());
  const Inertia inertia = solidBoxInertia(3.0, Vector3(0.5, 0.3, 0.1));
  addFreeBody(b, "box", inertia);
  const Model model = b.build();
  Data data(model);
  VectorX q0 = model.neutralConfiguration();
  VectorX v0(6);
  v0 << 0.1, -0.2, 0.3, 0.2, 5.0, 0.3;  // spin near the unstable intermediate axis: it tumbles
  SmoothReferenceIntegrator cvode(model);
  cvode.reset(0.0, q0, v0);
  const auto angularMomentum = [&](const VectorX& q, const VectorX& v) {
    forwardKinematics(model, data, q, v);
    return Vector3(data.world_pose[0].rotation * (inertia.inertia_com * v.tail<3>()));
  };
  const double e0 = totalEnergy(model, data, q0, v0);
  const Vector3 l0 = angularMomentum(q0, v0);
  double energy_drift = 0.0, momentum_drift = 0.0, max_flip = 0.0;
  for (int k = 1; k <= 100; ++k) {
    cvode.advanceTo(0.1 * k);
    energy_drift =
        std::max(energy_drift, std::abs(totalEnergy(model, data, cvode.q(), cvode.v()) - e0));
    momentum_drift = std::max(momentum_drift, (angularMomentum(cvode.q(), cvode.v()) - l0).norm());
    max_flip = std::max(max_flip, std::abs(cvode.v()[4] - v0[4]));
  }
  EXPECT_LT(energy_drift / e0, 1e-8);
  EXPECT_LT(momentum_drift / l0.norm(), 1e-8);
  EXPECT_GT(max_flip, 5.0);  // the spin reversed at least once: a real tumble
  // linear momentum: the centre moves uniformly
  EXPECT_LT((cvode.q().head<3>() - 10.0 * v0.head<3>()).norm(), 1e-9);
}

TEST(SmoothReference, ArticulatedFloatingBaseKeepsEnergy) {
  const Model model = test::floatingArm();
  Data data(model);
  std::mt19937 rng(41);
  const VectorX q0 = test::randomConfiguration(model, rng);
  const VectorX v0 = test::randomVector(model.nv, rng);
  SmoothReferenceIntegrator cvode(model);
  cvode.reset(0.0, q0, v0);
  const double e0 = totalEnergy(model, data, q0, v0);
  cvode.advanceTo(2.0);
  EXPECT_LT(std::abs(totalEnergy(model, data, cvode.q(), cvode.v()) - e0) / std::abs(e0), 1e-8);
}

TEST(SmoothReference, AppliedForceDoesWork) {
  // a 1-dof pendulum driven by a constant torque: energy grows by the torque's work
  ModelBuilder b;
  b.setGravity(Vector3::Zero());
  b.addBody(-1, "pin", Joint::revolute(Vector3::UnitZ()), Pose{},
            Inertia{2.0, Vector3(0.5, 0, 0), Matrix3::Identity() * 0.1}, "rod");
  const Model model = b.build();
  SmoothReferenceIntegrator cvode(
      model, {}, [](double, const VectorX&, const VectorX&, VectorX& tau) { tau[0] = 0.3; });
  cvode.reset(0.0, VectorX::Zero(1), VectorX::Zero(1));
  cvode.advanceTo(1.0);
  const double inertia_about_pin = 0.1 + 2.0 * 0.25;
  EXPECT_NEAR(cvode.v()[0], 0.3 / inertia_about_pin, 1e-10);
  EXPECT_NEAR(cvode.q()[0], 0.5 * 0.3 / inertia_about_pin, 1e-10);
}

TEST(SmoothReference, RejectsBadSettingsAndStates) {
  const Model model = doublePendulum();
  SmoothReferenceSettings bad;
  bad.relative_tolerance = -1.0;
  EXPECT_THROW(SmoothReferenceIntegrator(model, bad), InputError);
  SmoothReferenceIntegrator cvode(model);
  VectorX q(2);
  q << std::nan(""), 0.0;
  EXPECT_THROW(cvode.reset(0.0, q, VectorX::Zero(2)), InputError);
  EXPECT_THROW(cvode.reset(0.0, VectorX::Zero(3), VectorX::Zero(2)), InputError);
}

}  // namespace
}  // namespace sweep
