#include "framework/configuration.hpp"

#include <gtest/gtest.h>

#include "framework/kinematics.hpp"
#include "test_models.hpp"

namespace sweep {
namespace {

class ConfigurationTest : public ::testing::TestWithParam<int> {};

TEST_P(ConfigurationTest, DifferenceInvertsIntegrate) {
  const auto models = test::allModels();
  const Model& model = models[GetParam()].model;
  std::mt19937 rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    const VectorX q = test::randomConfiguration(model, rng);
    const VectorX dv = test::randomVector(model.nv, rng);  // rotations below pi
    const VectorX q1 = integrate(model, q, dv);
    EXPECT_LT((difference(model, q, q1) - dv).norm(), 1e-12);
    EXPECT_LT(difference(model, q1, q1).norm(), 1e-12);
  }
}

TEST_P(ConfigurationTest, ConfigurationRateIsDerivativeOfIntegrate) {
  const auto models = test::allModels();
  const Model& model = models[GetParam()].model;
  std::mt19937 rng(11);
  const VectorX q = test::randomConfiguration(model, rng);
  const VectorX v = test::randomVector(model.nv, rng);
  VectorX qdot;
  configurationRate(model, q, v, qdot);
  const double eps = 1e-6;
  const VectorX fd = (integrate(model, q, eps * v) - integrate(model, q, -eps * v)) / (2 * eps);
  // central differences: error O(eps^2)
  EXPECT_LT((fd - qdot).norm(), 1e-8);
}

TEST(Configuration, QuaternionsStayUnitAndNqDiffersFromNv) {
  const Model model = test::floatingArm();
  EXPECT_EQ(model.nq, model.nv + 1);
  VectorX q = model.neutralConfiguration();
  VectorX dv = VectorX::Zero(model.nv);
  dv.segment<3>(3) = Vector3(0.3, -2.0, 1.1);
  for (int k = 0; k < 1000; ++k) q = integrate(model, q, dv);
  EXPECT_NEAR(q.segment<4>(3).norm(), 1.0, 1e-14);
}

TEST(Configuration, PlanarAnglesAddExactly) {
  ModelBuilder b;
  addPlanarBody(b, "disk", solidDiskInertia(1.0, 0.1));
  const Model model = b.build();
  VectorX q(3), dv(3);
  q << 1.0, 2.0, 3.0;
  dv << 0.5, -0.25, 10.0;  // angles are not wrapped: a spinning disk counts its turns
  EXPECT_EQ(integrate(model, q, dv), q + dv);
}

// The body-frame velocity of a floating joint is its body's spatial velocity in body
// coordinates, which the kinematics computes on its own: (angular, linear) there.
TEST_P(ConfigurationTest, BodyFrameVelocityIsTheBodysOwnTwist) {
  const auto models = test::allModels();
  const Model& model = models[GetParam()].model;
  std::mt19937 rng(11);
  const VectorX q = test::randomConfiguration(model, rng);
  const VectorX v = test::randomVector(model.nv, rng);
  const VectorX body = velocityToBodyFrame(model, q, v);
  EXPECT_LT((velocityFromBodyFrame(model, q, body) - v).norm(), 1e-14 * v.norm());
  Data data(model);
  forwardKinematics(model, data, q, v);
  int floating = 0;
  for (std::size_t b = 0; b < model.bodies.size(); ++b) {
    const Body& body_b = model.bodies[b];
    if (body_b.joint.type != JointType::Floating) {
      for (int k = 0; k < body_b.joint.nv(); ++k)
        EXPECT_EQ(body[body_b.v_index + k], v[body_b.v_index + k]);
      continue;
    }
    ++floating;
    if (body_b.parent >= 0) continue;  // a root: its twist is its joint's
    EXPECT_LT((body.segment<3>(body_b.v_index) - data.velocity[b].tail<3>()).norm(), 1e-12);
    EXPECT_LT((body.segment<3>(body_b.v_index + 3) - data.velocity[b].head<3>()).norm(), 1e-12);
  }
  if (floating == 0) {
    EXPECT_EQ(body, v);
  }
}

INSTANTIATE_TEST_SUITE_P(AllModels, ConfigurationTest, ::testing::Range(0, test::modelCount()),
                         test::modelName);

// A subset of the body trees (Data::componentSubset): the passes over trees visit those only;
// integrate copies the others' coordinates, and forwardKinematics leaves their poses as they
// were (a rank of a distributed run steps its own and ghost grains only).
TEST(Configuration, AComponentSubsetMovesItsTreesOnly) {
  ModelBuilder b;
  for (int i = 0; i < 4; ++i)
    addFreeBody(b, "ball" + std::to_string(i), solidSphereInertia(1.0, 0.1));
  const Model model = b.build();
  ASSERT_EQ(model.components.size(), 4u);
  std::mt19937 rng(5);
  const VectorX q = test::randomConfiguration(model, rng);
  const VectorX dv = test::randomVector(model.nv, rng);
  const std::vector<int> subset{1, 3};
  VectorX moved;
  integrate(model, q, dv, moved, 1, &subset);
  const VectorX all = integrate(model, q, dv);
  Data data(model), whole(model);
  forwardKinematics(model, whole, all);
  data.restrict_components = true;
  data.components = subset;
  forwardKinematics(model, data, moved);
  for (int c = 0; c < 4; ++c) {
    const Component& comp = model.components[c];
    const bool in = c == 1 || c == 3;
    const VectorX expected = (in ? all : q).segment(comp.q_index, comp.nq);
    EXPECT_EQ(moved.segment(comp.q_index, comp.nq), expected) << c;
    const Pose& pose = data.world_pose[comp.first_body];
    if (in) {
      EXPECT_EQ(pose.translation, whole.world_pose[comp.first_body].translation) << c;
    } else {
      EXPECT_EQ(pose.translation, Vector3::Zero()) << c;  // never computed
    }
  }
}

}  // namespace
}  // namespace sweep
