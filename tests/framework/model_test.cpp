#include "framework/model.hpp"

#include <gtest/gtest.h>

#include "framework/error.hpp"
#include "test_models.hpp"

namespace sweep {
namespace {

TEST(Model, ComponentsAreContiguousWhateverTheOrderOfAddition) {
  ModelBuilder b;
  const Inertia in{1.0, Vector3(0.1, 0, 0), Matrix3::Identity() * 0.01};
  const int a = b.addBody(-1, "ja", Joint::revolute(Vector3::UnitZ()), Pose{}, in, "a");
  const int c = b.addBody(-1, "jc", Joint::floating(), Pose{}, in, "c");
  b.addBody(a, "ja2", Joint::prismatic(Vector3::UnitX()), Pose{}, in, "a2");
  b.addBody(c, "jc2", Joint::revolute(Vector3::UnitY()), Pose{}, in, "c2");
  const Model m = b.build();
  ASSERT_EQ(m.components.size(), 2u);
  EXPECT_EQ(m.nq, 1 + 1 + 7 + 1);
  EXPECT_EQ(m.nv, 1 + 1 + 6 + 1);
  EXPECT_EQ(m.bodies[m.bodyIndex("a2")].parent, m.bodyIndex("a"));
  EXPECT_EQ(m.bodies[m.bodyIndex("c2")].parent, m.bodyIndex("c"));
  const Component& second = m.components[1];
  EXPECT_EQ(second.v_index, 2);
  EXPECT_EQ(second.nv, 7);
  EXPECT_EQ(second.nq, 8);
  for (const Body& body : m.bodies) {
    const Component& comp = m.componentOf(&body - m.bodies.data());
    EXPECT_GE(body.v_index, comp.v_index);
    EXPECT_LE(body.v_index + body.joint.nv(), comp.v_index + comp.nv);
  }
  EXPECT_EQ(m.jointIndex("jc2"), m.bodyIndex("c2"));
  EXPECT_THROW(m.bodyIndex("nope"), InputError);
}

TEST(Model, JointLimitsBecomeUnilateralConstraints) {
  ModelBuilder b;
  const Inertia in{1.0, Vector3(0.1, 0, 0), Matrix3::Identity() * 0.01};
  const int a = b.addBody(-1, "j", Joint::revolute(Vector3::UnitZ()), Pose{}, in, "a");
  b.addJointLimits(a, -0.5, 1.0);
  const Model m = b.build();
  ASSERT_EQ(m.limits.size(), 2u);
  // gap = side (q - bound) is >= 0 exactly inside [lower, upper]
  for (double q : {-0.5, 0.0, 1.0}) {
    for (const JointLimit& l : m.limits) EXPECT_GE(l.side * (q - l.bound), 0.0);
  }
  EXPECT_LT(m.limits[0].side * (-0.6 - m.limits[0].bound), 0.0);
  EXPECT_LT(m.limits[1].side * (1.1 - m.limits[1].bound), 0.0);
  EXPECT_THROW(b.addJointLimits(a, 1.0, -1.0), InputError);
}

TEST(Model, RejectsBadBodies) {
  ModelBuilder b("unit");
  Inertia negative{-1.0, Vector3::Zero(), Matrix3::Identity()};
  try {
    b.addBody(-1, "j", Joint::fixed(), Pose{}, negative, "bad");
    FAIL() << "negative mass accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("body 'bad': mass must be >= 0"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(b.addBody(5, "j", Joint::fixed(), Pose{}, Inertia{}, "orphan"), InputError);
  Joint zero_axis = Joint::revolute(Vector3::UnitX());
  zero_axis.axis = Vector3::Zero();
  EXPECT_THROW(b.addBody(-1, "j", zero_axis, Pose{}, Inertia{}, "x"), InputError);
  EXPECT_THROW(b.setGravity(Vector3(0, std::nan(""), 0)), InputError);
}

TEST(Model, RejectsDegreeOfFreedomWithoutInertia) {
  ModelBuilder b("massless");
  b.addBody(-1, "spin", Joint::revolute(Vector3::UnitZ()), Pose{}, Inertia::zero(), "ghost");
  try {
    b.build();
    FAIL() << "singular mass matrix accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("singular"), std::string::npos) << e.what();
  }
}

TEST(Model, RejectsDuplicateNames) {
  ModelBuilder b;
  addPlanarBody(b, "disk", solidDiskInertia(1.0, 0.1));
  addPlanarBody(b, "disk", solidDiskInertia(1.0, 0.1));
  EXPECT_THROW(b.build(), InputError);
}

TEST(Model, DrivenBodiesFollowTheirMotion) {
  Pose start;
  start.translation = Vector3(1, 2, 3);
  const DrivenBody blade =
      DrivenBody::constantTwist("blade", start, Vector3(0.1, 0, 0), Vector3(0, 0, 2.0));
  EXPECT_LT((blade.pose(2.0).translation - Vector3(1.2, 2, 3)).norm(), 1e-15);
  const Matrix3 expected = Eigen::AngleAxisd(4.0, Vector3::UnitZ()).toRotationMatrix();
  EXPECT_LT((blade.pose(2.0).rotation - expected).norm(), 1e-14);
  const Matrix3 backwards = Eigen::AngleAxisd(-1.0, Vector3::UnitZ()).toRotationMatrix();
  EXPECT_LT((blade.pose(-0.5).rotation - backwards).norm(), 1e-14);
  const DrivenBody wall = DrivenBody::fixed("wall", start);
  EXPECT_EQ(wall.pose(3.0).translation, start.translation);
  EXPECT_EQ(wall.twist(3.0), Vector6::Zero());
  EXPECT_EQ(blade.twist(5.0)[2], 2.0);
  EXPECT_EQ(blade.twist(5.0)[3], 0.1);
  ModelBuilder b;
  addPlanarBody(b, "disk", solidDiskInertia(1.0, 0.1));
  b.addDrivenBody(blade);
  const Model m = b.build();
  EXPECT_EQ(m.driven_bodies.size(), 1u);
  EXPECT_EQ(m.nv, 3);  // driven bodies have no degrees of freedom
}

}  // namespace
}  // namespace sweep
