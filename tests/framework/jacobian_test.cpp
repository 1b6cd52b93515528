#include "framework/jacobian.hpp"

#include <gtest/gtest.h>

#include "framework/configuration.hpp"
#include "framework/kinematics.hpp"
#include "models/rigid_bodies.hpp"
#include "test_models.hpp"

namespace sweep {
namespace {

class JacobianTest : public test::ModelTest {};

Vector3 rotationVector(const Matrix3& r) {
  const Eigen::AngleAxisd aa(r);
  return aa.angle() * aa.axis();
}

TEST_P(JacobianTest, EveryBodyPointMatchesFiniteDifferences) {
  const Model& model = *model_;
  Data data(model);
  std::mt19937 rng(29);
  const VectorX q = test::randomConfiguration(model, rng);
  const VectorX v = test::randomVector(model.nv, rng);
  forwardKinematics(model, data, q);
  const double eps = 1e-6;
  Data plus(model), minus(model);
  forwardKinematics(model, plus, integrate(model, q, eps * v));
  forwardKinematics(model, minus, integrate(model, q, -eps * v));
  for (size_t body = 0; body < model.bodies.size(); ++body) {
    const int b = static_cast<int>(body);
    const Vector3 local = Vector3(0.1, -0.2, 0.3);
    Eigen::Matrix<double, 6, Eigen::Dynamic> J =
        Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, model.nv);
    pointJacobian(model, data, b, bodyPointInWorld(data, b, local), J);
    const Vector6 twist = J * v;
    const Vector3 velocity_fd =
        (bodyPointInWorld(plus, b, local) - bodyPointInWorld(minus, b, local)) / (2 * eps);
    const Vector3 omega_fd =
        rotationVector(plus.world_pose[b].rotation * minus.world_pose[b].rotation.transpose()) /
        (2 * eps);
    EXPECT_LT((twist.tail<3>() - velocity_fd).norm(), 1e-7) << "body " << body;
    EXPECT_LT((twist.head<3>() - omega_fd).norm(), 1e-7) << "body " << body;
  }
}

TEST_P(JacobianTest, FrameJacobianAgreesWithBodyVelocity) {
  // the angular rows and the origin velocity match the spatial velocity of the kinematics
  const Model& model = *model_;
  Data data(model);
  std::mt19937 rng(31);
  const VectorX q = test::randomConfiguration(model, rng);
  const VectorX v = test::randomVector(model.nv, rng);
  forwardKinematics(model, data, q, v);
  for (size_t body = 0; body < model.bodies.size(); ++body) {
    Eigen::Matrix<double, 6, Eigen::Dynamic> J =
        Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, model.nv);
    frameJacobian(model, data, static_cast<int>(body), Pose{}, J);
    const Matrix3& r = data.world_pose[body].rotation;
    const Vector6& vb = data.velocity[body];
    EXPECT_LT(((J * v).head<3>() - r * vb.head<3>()).norm(), 1e-12);
    EXPECT_LT(((J * v).tail<3>() - r * vb.tail<3>()).norm(), 1e-12);
  }
}

// A floating joint's linear velocity is in its parent frame, so the point Jacobian's columns
// for it are that frame's axes exactly, whatever the body's orientation: the world axes for a
// free body. The contact rows of two spheres then share them to the bit (their body form).
TEST(FloatingJacobian, LinearColumnsAreTheParentAxesExactly) {
  ModelBuilder builder;
  addFreeBody(builder, "a", solidSphereInertia(1.3, 0.2));
  addFreeBody(builder, "b", solidSphereInertia(0.7, 0.1));
  const Model model = builder.build();
  Data data(model);
  std::mt19937 rng(37);
  forwardKinematics(model, data, test::randomConfiguration(model, rng));
  for (int b = 0; b < 2; ++b) {
    ASSERT_FALSE(data.world_pose[b].rotation.isIdentity(1e-3));  // a turned body
    Eigen::Matrix<double, 6, Eigen::Dynamic> J =
        Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, model.nv);
    pointJacobian(model, data, b, data.world_pose[b].translation + Vector3(0.05, -0.1, 0.2), J);
    const int first = model.bodies[b].v_index;
    EXPECT_TRUE((J.block<3, 3>(3, first) == Matrix3::Identity())) << J.block<3, 3>(3, first);
    EXPECT_TRUE((J.block<3, 3>(0, first).isZero(0.0)));
    // the angular columns: the body's axes (angular velocity in body axes)
    EXPECT_TRUE((J.block<3, 3>(0, first + 3) == data.world_pose[b].rotation));
  }
}

INSTANTIATE_TEST_SUITE_P(AllModels, JacobianTest, ::testing::Range(0, test::modelCount()),
                         test::modelName);

}  // namespace
}  // namespace sweep
