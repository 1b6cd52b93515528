#pragma once
// Models and random states shared by the framework tests.
#include <gtest/gtest.h>

#include <memory>
#include <random>
#include <string>
#include <vector>

#include "framework/model.hpp"
#include "framework/urdf_import.hpp"
#include "models/kinematic_trees.hpp"
#include "models/rigid_bodies.hpp"

namespace sweep::test {

struct NamedModel {
  std::string name;
  Model model;
};

// A floating base carrying a two-link arm, with the base frame away from its centre of mass.
inline Model floatingArm() {
  ModelBuilder b("floating arm");
  Inertia base = solidBoxInertia(5.0, Vector3(0.4, 0.3, 0.2));
  base.com = Vector3(0.05, -0.02, 0.03);
  const int root = b.addBody(-1, "base_joint", Joint::floating(), Pose{}, base, "base");
  Inertia link = solidBoxInertia(1.0, Vector3(0.3, 0.05, 0.05));
  link.com = Vector3(0.15, 0, 0);
  Pose at;
  at.translation = Vector3(0.2, 0.0, 0.1);
  const int l1 = b.addBody(root, "j1", Joint::revolute(Vector3(0, 1, 1)), at, link, "l1");
  Pose at2;
  at2.translation = Vector3(0.3, 0, 0);
  b.addBody(l1, "j2", Joint::prismatic(Vector3(1, 0, 0)), at2, link, "l2");
  return b.build();
}

// Planar body with an off-centre frame, carrying a pendulum.
inline Model planarWithPendulum() {
  ModelBuilder b("planar with pendulum");
  b.setGravity(Vector3(0, -9.81, 0));
  Inertia body = solidDiskInertia(2.0, 0.3);
  body.com = Vector3(0.1, 0.05, 0);
  const int root = b.addBody(-1, "plane", Joint::planar(), Pose{}, body, "disk");
  Inertia bob = solidDiskInertia(0.5, 0.05);
  bob.com = Vector3(0, -0.4, 0);
  b.addBody(root, "hinge", Joint::revolute(Vector3::UnitZ()), Pose{}, bob, "bob");
  return b.build();
}

// Several independent bodies: a block-diagonal M with constant and varying blocks.
inline Model mixedBodies() {
  ModelBuilder b("mixed bodies");
  addPlanarBody(b, "disk", solidDiskInertia(1.0, 0.2));
  addFreeBody(b, "box", solidBoxInertia(2.0, Vector3(0.3, 0.2, 0.1)));
  Inertia off = solidSphereInertia(1.5, 0.1);
  off.com = Vector3(0.02, 0.0, -0.01);
  addFreeBody(b, "offset_sphere", off);
  b.addBody(-1, "pin", Joint::revolute(Vector3::UnitZ()), Pose{},
            Inertia{1.0, Vector3(0, -1, 0), Matrix3::Identity() * 0.01}, "rod");
  return b.build();
}

inline UrdfOptions floatingBase() {
  UrdfOptions options;
  options.floating_base = true;
  return options;
}

inline std::vector<NamedModel> allModels() {
  DoublePendulumParameters p;
  p.tip_inertia = 0.01;
  return {{"double_pendulum", doublePendulum(p)},
          {"arm6", serialArm6()},
          {"tree30", branchedTree(30)},
          {"floating_arm", floatingArm()},
          {"planar_pendulum", planarWithPendulum()},
          {"mixed", mixedBodies()},
          {"urdf_arm6", loadUrdf(std::string(SWEEP_TEST_DATA) + "/urdf/arm6.urdf")},
          {"urdf_floating",
           loadUrdf(std::string(SWEEP_TEST_DATA) + "/urdf/floating_base.urdf", floatingBase())},
          {"urdf_planar_floating",
           loadUrdf(std::string(SWEEP_TEST_DATA) + "/urdf/planar_and_floating_joints.urdf")}};
}

inline bool hasQuaternions(const Model& m) {
  for (const Body& b : m.bodies)
    if (b.joint.type == JointType::Floating) return true;
  return false;
}

inline VectorX randomConfiguration(const Model& model, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  VectorX q(model.nq);
  for (int i = 0; i < model.nq; ++i) q[i] = u(rng);
  for (const Body& b : model.bodies)
    if (b.joint.type == JointType::Floating) q.segment<4>(b.q_index + 3).normalize();
  return q;
}

inline VectorX randomVector(int n, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  VectorX v(n);
  for (int i = 0; i < n; ++i) v[i] = u(rng);
  return v;
}

}  // namespace sweep::test

namespace sweep::test {

inline int modelCount() {
  return static_cast<int>(allModels().size());
}

// Fixture of the tests run on every model of allModels(); the parameter is the model index.
class ModelTest : public ::testing::TestWithParam<int> {
 protected:
  void SetUp() override { model_ = std::make_unique<Model>(allModels()[GetParam()].model); }
  std::unique_ptr<Model> model_;
};

// test-name suffix for a model index parameter
inline std::string modelName(const ::testing::TestParamInfo<int>& info) {
  return allModels()[info.param].name;
}

}  // namespace sweep::test
