#include "models/rigid_bodies.hpp"

#include <gtest/gtest.h>

#include "framework/error.hpp"

namespace sweep {
namespace {

TEST(RigidBodies, SolidInertias) {
  const Inertia box = solidBoxInertia(12.0, Vector3(1.0, 2.0, 3.0));
  EXPECT_DOUBLE_EQ(box.inertia_com(0, 0), 4.0 + 9.0);
  EXPECT_DOUBLE_EQ(box.inertia_com(1, 1), 1.0 + 9.0);
  EXPECT_DOUBLE_EQ(box.inertia_com(2, 2), 1.0 + 4.0);
  EXPECT_DOUBLE_EQ(solidSphereInertia(5.0, 2.0).inertia_com(1, 1), 8.0);
  EXPECT_DOUBLE_EQ(solidDiskInertia(2.0, 3.0).inertia_com(2, 2), 9.0);
}

TEST(RigidBodies, RejectNonPositiveSizes) {
  EXPECT_THROW(solidDiskInertia(1.0, -0.3e-3), InputError);
  EXPECT_THROW(solidSphereInertia(0.0, 1.0), InputError);
  EXPECT_THROW(solidBoxInertia(1.0, Vector3(1, std::nan(""), 1)), InputError);
  try {
    solidDiskInertia(1.0, -0.3e-3);
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("radius must be > 0, got -0.0003"), std::string::npos)
        << e.what();
  }
}

TEST(RigidBodies, ParticlesHaveConstantDiagonalMass) {
  ModelBuilder b;
  for (int i = 0; i < 10; ++i)
    addPlanarBody(b, "disk" + std::to_string(i), solidDiskInertia(1.0, 0.1));
  addFreeBody(b, "sphere", solidSphereInertia(2.0, 0.1));
  const Model m = b.build();
  EXPECT_EQ(m.nv, 30 + 6);
  for (const Component& c : m.components) EXPECT_TRUE(c.constant_mass);
}

}  // namespace
}  // namespace sweep
