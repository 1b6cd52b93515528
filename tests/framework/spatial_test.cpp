#include "framework/spatial.hpp"

#include <gtest/gtest.h>

namespace sweep {
namespace {

Pose randomPose(int seed) {
  std::srand(seed);
  Pose p;
  p.rotation = Quaternion(Eigen::Vector4d::Random().normalized()).toRotationMatrix();
  p.translation = Vector3::Random();
  return p;
}

TEST(Spatial, MotionTransformsAreInverse) {
  const Pose x = randomPose(1);
  const Vector6 m = Vector6::Random();
  EXPECT_LT((x.motionToParent(x.motionToChild(m)) - m).norm(), 1e-14);
  EXPECT_LT((x.inverse().motionToChild(m) - x.motionToParent(m)).norm(), 1e-14);
}

TEST(Spatial, PowerIsFrameIndependent) {
  // f . m is the power, a scalar: the same in every frame
  const Pose x = randomPose(2);
  const Vector6 m_child = Vector6::Random();
  const Vector6 f_child = Vector6::Random();
  EXPECT_NEAR(x.forceToParent(f_child).dot(x.motionToParent(m_child)), f_child.dot(m_child), 1e-13);
}

TEST(Spatial, InertiaMatchesSixBySixMatrix) {
  Inertia in{2.5, Vector3(0.1, -0.2, 0.3), Matrix3::Zero()};
  in.inertia_com << 0.3, 0.01, 0.02, 0.01, 0.4, -0.03, 0.02, -0.03, 0.5;
  const Vector6 m = Vector6::Random();
  EXPECT_LT((in.apply(m) - in.matrix() * m).norm(), 1e-14);
}

TEST(Spatial, InertiaChangeOfFrameIsCongruence) {
  Inertia in{1.5, Vector3(0.2, 0.1, -0.1), Matrix3::Identity() * 0.2};
  in.inertia_com(0, 1) = in.inertia_com(1, 0) = 0.05;
  const Pose x = randomPose(3);
  const Vector6 m_parent = Vector6::Random();
  // momentum computed in the child frame and carried back equals momentum in the parent frame
  const Vector6 via_child = x.forceToParent(in.apply(x.motionToChild(m_parent)));
  EXPECT_LT((in.expressedIn(x).apply(m_parent) - via_child).norm(), 1e-13);
}

TEST(Spatial, InertiaSumIsAdditive) {
  Inertia a{1.0, Vector3(0.1, 0, 0), Matrix3::Identity() * 0.1};
  Inertia b{3.0, Vector3(-0.2, 0.3, 0.1), Matrix3::Identity() * 0.05};
  Inertia zero = Inertia::zero();
  const Vector6 m = Vector6::Random();
  Inertia sum = a;
  sum += b;
  EXPECT_LT((sum.apply(m) - a.apply(m) - b.apply(m)).norm(), 1e-13);
  zero += a;
  EXPECT_LT((zero.apply(m) - a.apply(m)).norm(), 1e-14);
}

TEST(Spatial, CrossProductsAreDual) {
  // (v x* f) . m = -f . (v x m)
  const Vector6 v = Vector6::Random(), f = Vector6::Random(), m = Vector6::Random();
  EXPECT_NEAR(crossForce(v, f).dot(m), -f.dot(crossMotion(v, m)), 1e-13);
}

}  // namespace
}  // namespace sweep
