#include "framework/urdf_import.hpp"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

#include "framework/crba.hpp"
#include "framework/error.hpp"
#include "framework/kinematics.hpp"
#include "framework/rnea.hpp"
#include "models/kinematic_trees.hpp"
#include "test_models.hpp"

namespace sweep {
namespace {

std::string urdfPath(const std::string& name) {
  return std::string(SWEEP_TEST_DATA) + "/urdf/" + name;
}

TEST(UrdfImport, DoublePendulumMatchesHandCodedModel) {
  Model from_urdf = loadUrdf(urdfPath("double_pendulum.urdf"));
  DoublePendulumParameters p;
  p.tip_inertia = 0.01;
  const Model coded = doublePendulum(p);
  from_urdf.gravity = coded.gravity;  // URDF carries no gravity
  ASSERT_EQ(from_urdf.nv, 2);
  Data a(from_urdf), b(coded);
  std::mt19937 rng(37);
  for (int trial = 0; trial < 5; ++trial) {
    const VectorX q = test::randomConfiguration(coded, rng);
    const VectorX v = test::randomVector(2, rng);
    crba(from_urdf, a, q);
    crba(coded, b, q);
    EXPECT_LT((denseMassMatrix(from_urdf, a) - denseMassMatrix(coded, b)).norm(), 1e-13);
    EXPECT_LT((biasForces(from_urdf, a, q, v) - biasForces(coded, b, q, v)).norm(), 1e-12);
  }
  // "world" root: the joints attach to the world, no extra body
  EXPECT_EQ(from_urdf.bodies.size(), 2u);
  EXPECT_EQ(from_urdf.bodies[from_urdf.jointIndex("elbow")].name, "lower");
}

TEST(UrdfImport, ArmWithOffsetsLimitsAndCollisions) {
  const Model m = loadUrdf(urdfPath("arm6.urdf"));
  EXPECT_EQ(m.nq, 6);
  EXPECT_EQ(m.nv, 6);
  EXPECT_EQ(m.bodies.size(), 8u);   // base, six links, tool0 (fixed)
  EXPECT_EQ(m.limits.size(), 10u);  // five limited joints, continuous joint6 unlimited
  const JointLimit& lower = m.limits[0];
  EXPECT_EQ(lower.q_index, m.bodies[m.jointIndex("joint1")].q_index);
  EXPECT_DOUBLE_EQ(lower.bound, -3.0);
  ASSERT_EQ(m.collisions.size(), 5u);
  int meshes = 0;
  for (const CollisionGeometry& g : m.collisions) {
    if (g.type != GeometryType::Mesh) continue;
    ++meshes;
    EXPECT_EQ(g.mesh_file, urdfPath("meshes/link3.stl"));
    EXPECT_DOUBLE_EQ(g.mesh_scale.x(), 0.001);
    EXPECT_EQ(m.bodies[g.body].name, "link3");
  }
  EXPECT_EQ(meshes, 1);
  // the inertial rpy rotates the tensor: trace is invariant, the diagonal is not
  const Inertia& link1 = m.bodies[m.bodyIndex("link1")].inertia;
  EXPECT_NEAR(link1.inertia_com.trace(), 0.040 + 0.045 + 0.030, 1e-14);
  EXPECT_GT(std::abs(link1.inertia_com(0, 0) - 0.040), 1e-4);
  EXPECT_LT((link1.com - Vector3(0.01, 0.02, 0.08)).norm(), 1e-15);
}

TEST(UrdfImport, BranchedTree) {
  const Model m = loadUrdf(urdfPath("branched.urdf"));
  EXPECT_EQ(m.nv, 4);
  const int torso = m.bodyIndex("torso");
  EXPECT_EQ(m.bodies[m.bodyIndex("left_upper")].parent, torso);
  EXPECT_EQ(m.bodies[m.bodyIndex("right_upper")].parent, torso);
  EXPECT_EQ(m.bodies[m.jointIndex("right_extend")].joint.type, JointType::Prismatic);
  // left_elbow's limits are [0, 2.5]: URDF's explicit zero lower bound is kept
  int elbow_limits = 0;
  for (const JointLimit& l : m.limits)
    if (l.body == m.jointIndex("left_elbow")) ++elbow_limits;
  EXPECT_EQ(elbow_limits, 2);
}

TEST(UrdfImport, FloatingBase) {
  const Model fixed = loadUrdf(urdfPath("floating_base.urdf"));
  UrdfOptions options;
  options.floating_base = true;
  options.name_prefix = "robot1/";
  const Model floating = loadUrdf(urdfPath("floating_base.urdf"), options);
  EXPECT_EQ(fixed.nv, 2);
  EXPECT_EQ(floating.nq, 7 + 2);
  EXPECT_EQ(floating.nv, 6 + 2);
  EXPECT_EQ(floating.bodies[0].joint.type, JointType::Floating);
  EXPECT_EQ(floating.bodies[0].name, "robot1/body");
  EXPECT_NO_THROW(floating.jointIndex("robot1/knee"));
}

TEST(UrdfImport, PlanarAndFloatingJointTypes) {
  const Model m = loadUrdf(urdfPath("planar_and_floating_joints.urdf"));
  EXPECT_EQ(m.nq, 3 + 7);
  EXPECT_EQ(m.nv, 3 + 6);
  const Body& cart = m.bodies[m.jointIndex("rail")];
  EXPECT_EQ(cart.joint.type, JointType::Planar);
  EXPECT_LT((cart.joint.axis - Vector3::UnitY()).norm(), 1e-15);
  EXPECT_EQ(m.bodies[m.jointIndex("float")].joint.type, JointType::Floating);
  // the planar joint moves the cart in the plane normal to y: its height changes, y does not
  Data data(m);
  VectorX q = m.neutralConfiguration();
  q.head<3>() << 0.3, -0.2, 0.5;
  forwardKinematics(m, data, q);
  const Vector3 p = data.world_pose[m.bodyIndex("cart")].translation;
  EXPECT_NEAR(p.y(), 0.0, 1e-15);
  EXPECT_NEAR((p - Vector3(0, 0, 1)).norm(), std::hypot(0.3, 0.2), 1e-15);
}

struct BadUrdf {
  std::string file;
  std::string expected;  // part of the message
};

class BadUrdfTest : public ::testing::TestWithParam<BadUrdf> {};

TEST_P(BadUrdfTest, ClearErrorNamingFileElementAndReason) {
  const BadUrdf& bad = GetParam();
  const std::string path = urdfPath("bad/" + bad.file);
  try {
    loadUrdf(path);
    FAIL() << bad.file << " was accepted";
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(path), std::string::npos) << message;
    EXPECT_NE(message.find(bad.expected), std::string::npos) << message;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Catalogue, BadUrdfTest,
    ::testing::Values(
        BadUrdf{"missing.urdf", "does not exist"},
        BadUrdf{"malformed.urdf", "line 5, column 3: malformed XML"},
        BadUrdf{"unknown_joint_type.urdf", "helical"},
        BadUrdf{"negative_mass.urdf", "link 'b' <inertial>: mass must be >= 0, got -2.5"},
        BadUrdf{"inertia_not_positive.urdf",
                "link 'b' <inertial>: inertia tensor is not positive definite"},
        BadUrdf{"inertia_triangle.urdf", "violate the triangle inequality"},
        BadUrdf{"two_parents.urdf", "link 'c' has two parents"},
        BadUrdf{"joint_loop.urdf", "closes a loop: link 'a' is its own ancestor"},
        BadUrdf{"self_parent.urdf", "joint 'spin' closes a loop: link 'a' is its own ancestor"},
        BadUrdf{"zero_axis.urdf", "joint 'j': axis must have non-zero length"},
        BadUrdf{"format_in_number.urdf", "holds a '%' (first on line 8)"},
        BadUrdf{"inertial_origin.urdf", "urdfdom reported an error and left part of the file out"},
        // Latin-1 text: the parser would read it as UTF-8 (and TinyXML past the buffer's end)
        BadUrdf{"invalid_utf8.urdf", "line 3: not valid UTF-8 (byte 0xE9 at offset 56)"},
        BadUrdf{"mimic_unknown_leader.urdf",
                "joint 'finger_right' <mimic>: it follows joint 'finger_left', which is not in "
                "the file"},
        BadUrdf{"mimic_fixed_leader.urdf",
                "joint 'finger_right' <mimic>: mimic needs revolute, continuous or prismatic "
                "joints; joint 'palm_mount' is not"},
        BadUrdf{"origin_far.urdf",
                "joint 'shoulder' <origin>: xyz [0 0 -1e+300] is beyond 1e+06 m"},
        BadUrdf{"mimic_cycle.urdf",
                "joint 'finger_right' following 'finger_left': the couplings form a cycle"},
        BadUrdf{"mesh_scale_zero.urdf",
                "link 'a' <collision>: mesh scale must be > 0 and finite in each axis, got "
                "\"0 0 0\""},
        BadUrdf{"deep_nesting.urdf",
                "line 3: elements nested more than 100 levels deep; a URDF nests about 5"}),
    [](const ::testing::TestParamInfo<BadUrdf>& param_info) {
      return param_info.param.file.substr(0, param_info.param.file.find('.'));
    });

// A bound <limit> does not write is no bound (urdfdom reads it as 0), and a joint whose bounds
// are written equal is locked: two limits at the same value.
TEST(UrdfImport, LimitsAreTheBoundsTheFileWrites) {
  const Model model = loadUrdf(urdfPath("limits_as_written.urdf"));
  std::map<std::string, std::vector<std::pair<double, double>>> limits;
  for (const JointLimit& l : model.limits)
    limits[model.bodies[l.body].joint_name].push_back({l.bound, l.side});
  using Bounds = std::vector<std::pair<double, double>>;
  EXPECT_EQ(limits["locked"], (Bounds{{0.2, 1.0}, {0.2, -1.0}}));
  EXPECT_EQ(limits["lower_only"], (Bounds{{-0.1, 1.0}}));
  EXPECT_EQ(limits.count("unbounded"), 0u);
}

// package://PKG/... resolves as ROS tools resolve it: through package_paths, then
// $ROS_PACKAGE_PATH (a folder PKG holding package.xml, a few levels down), then the folders
// above the URDF file.
TEST(UrdfImport, PackageMeshesResolveThroughPathsTheEnvironmentAndTheFileItself) {
  const std::string data = SWEEP_TEST_DATA;
  const std::string mesh = data + "/packages/src/toy_description/meshes/link.stl";
  const auto only = [](const Model& model) {
    EXPECT_EQ(model.collisions.size(), 1u);
    return model.collisions.empty() ? CollisionGeometry{} : model.collisions[0];
  };
  ASSERT_EQ(std::getenv("ROS_PACKAGE_PATH"), nullptr) << "the test sets it itself";
  // inside its package: found above the file
  const CollisionGeometry inside =
      only(loadUrdf(data + "/packages/src/toy_description/urdf/toy.urdf"));
  EXPECT_EQ(inside.missing_mesh, "");
  EXPECT_TRUE(std::filesystem::equivalent(inside.mesh_file, mesh)) << inside.mesh_file;
  // outside it: not found, and said so, until a path leads there
  const std::string outside = data + "/urdf/toy_outside.urdf";
  EXPECT_NE(only(loadUrdf(outside))
                .missing_mesh.find("package 'toy_description' not found in "
                                   "package_paths [], ROS_PACKAGE_PATH (unset)"),
            std::string::npos);
  UrdfOptions options;
  options.package_paths = {data + "/meshes", data + "/packages"};
  const CollisionGeometry by_path = only(loadUrdf(outside, options));
  EXPECT_EQ(by_path.missing_mesh, "");
  EXPECT_TRUE(std::filesystem::equivalent(by_path.mesh_file, mesh)) << by_path.mesh_file;
  ASSERT_EQ(setenv("ROS_PACKAGE_PATH", ("/nonexistent:" + data + "/packages/src").c_str(), 1), 0);
  const CollisionGeometry by_environment = only(loadUrdf(outside));
  unsetenv("ROS_PACKAGE_PATH");
  EXPECT_EQ(by_environment.missing_mesh, "");
  EXPECT_TRUE(std::filesystem::equivalent(by_environment.mesh_file, mesh));
}

// A collision mesh the package does not ship: kept for the contact layer to refuse (the
// default), left out, or replaced by the box of the link's mass and inertia; noted either way.
TEST(UrdfImport, MissingMeshesAreRefusedLeftOutOrBoxed) {
  const std::string data = SWEEP_TEST_DATA;
  UrdfOptions options;
  options.package_paths = {data + "/packages"};
  const std::string path = data + "/urdf/toy_missing_mesh.urdf";
  const Model refused = loadUrdf(path, options);
  ASSERT_EQ(refused.collisions.size(), 1u);
  EXPECT_NE(refused.collisions[0].missing_mesh.find("mesh file not found"), std::string::npos);
  EXPECT_TRUE(refused.notes.empty());
  options.missing_meshes = MissingMeshes::Skip;
  const Model skipped = loadUrdf(path, options);
  EXPECT_TRUE(skipped.collisions.empty());
  ASSERT_EQ(skipped.notes.size(), 1u);
  EXPECT_NE(skipped.notes[0].find("link 'arm': mesh " + data +
                                  "/packages/src/toy_description/meshes/arm_collision.dae: mesh "
                                  "file not found (the URDF names 'package://toy_description/"
                                  "meshes/arm_collision.dae')"),
            std::string::npos)
      << skipped.notes[0];
  options.missing_meshes = MissingMeshes::InertiaBox;
  const Model boxed = loadUrdf(path, options);
  ASSERT_EQ(boxed.collisions.size(), 1u);
  const CollisionGeometry& box = boxed.collisions[0];
  EXPECT_EQ(box.type, GeometryType::Box);
  // the box 0.1 x 0.2 x 0.3 m whose inertia the link has, along its principal axes
  const Vector3 world_edges = (box.placement.rotation * box.box_size).cwiseAbs();
  EXPECT_NEAR(world_edges.x(), 0.1, 1e-9);
  EXPECT_NEAR(world_edges.y(), 0.2, 1e-9);
  EXPECT_NEAR(world_edges.z(), 0.3, 1e-9);
  EXPECT_NEAR((box.placement.translation - Vector3(0, 0, 0.15)).norm(), 0.0, 1e-12);
  EXPECT_NE(boxed.notes.at(0).find("its inertia box collides instead"), std::string::npos);
}

// The URDF fuzzer's find: lead bytes that promise more bytes than the text holds made TinyXML
// read past the end of the buffer (an AddressSanitizer heap-buffer-overflow). They are refused
// before any parser sees them; valid multi-byte names still load.
// <visual> elements are read for drawing only: a good one is kept on its body, one that is
// malformed or whose mesh is missing is noted and left out; the robot loads either way.
TEST(UrdfImport, VisualsAreKeptOrNotedNeverRefused) {
  const std::string urdf =
      "<robot name='r'><link name='base'/><link name='arm'><inertial><mass value='1'/>"
      "<inertia ixx='1' ixy='0' ixz='0' iyy='1' iyz='0' izz='1'/></inertial>"
      "<visual><origin xyz='0 0 0.5'/><geometry><box size='0.1 0.2 0.3'/></geometry></visual>"
      "<visual><geometry><sphere radius='-1'/></geometry></visual>"
      "<visual><geometry><mesh filename='no_such_visual.dae'/></geometry></visual>"
      "</link><joint name='j' type='continuous'><parent link='base'/><child link='arm'/>"
      "<axis xyz='0 0 1'/></joint></robot>";
  ModelBuilder b;
  addUrdfString(b, urdf, "r.urdf");
  const Model model = b.build();
  ASSERT_EQ(model.visuals.size(), 1u);
  EXPECT_EQ(model.visuals[0].type, GeometryType::Box);
  EXPECT_EQ(model.visuals[0].body, model.bodyIndex("arm"));
  EXPECT_DOUBLE_EQ(model.visuals[0].placement.translation.z(), 0.5);
  ASSERT_EQ(model.notes.size(), 2u);
  EXPECT_NE(model.notes[0].find("link 'arm' <visual>: sphere radius must be > 0"),
            std::string::npos)
      << model.notes[0];
  EXPECT_NE(model.notes[1].find("visual mesh"), std::string::npos) << model.notes[1];
  EXPECT_NE(model.notes[1].find("no_such_visual.dae"), std::string::npos) << model.notes[1];
}

TEST(UrdfImport, TruncatedUtf8IsRefusedBeforeParsing) {
  for (const std::string& tail :
       {std::string("\xdc"), std::string(40, '\xff') + std::string(30, '\xdc'),
        std::string("\xf0\x9f\x98"), std::string("\xed\xa0\x80"), std::string("\xc0\xaf")}) {
    ModelBuilder b;
    try {
      addUrdfString(b, "<robot name='r'><link name='a" + tail, "tail.urdf");
      FAIL() << "accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("tail.urdf: line 1: not valid UTF-8"), std::string::npos)
          << e.what();
    }
  }
  ModelBuilder b;
  addUrdfString(b,
                "<robot name='r'><link name='caf\xc3\xa9 \xe2\x88\x86 \xf0\x9f\x98\x80'><inertial>"
                "<mass value='1'/><inertia ixx='1' ixy='0' ixz='0' iyy='1' iyz='0' izz='1'/>"
                "</inertial></link></robot>",
                "utf8.urdf");
  EXPECT_GE(b.build().bodyIndex("caf\xc3\xa9 \xe2\x88\x86 \xf0\x9f\x98\x80"), 0);
}

std::string chainUrdf(int links) {
  std::string xml = "<robot name='chain'>";
  const std::string inertial =
      "<inertial><mass value='1'/><inertia ixx='1' ixy='0' ixz='0' iyy='1' iyz='0' izz='1'/>"
      "</inertial>";
  for (int i = 0; i <= links; ++i)
    xml += "<link name='l" + std::to_string(i) + "'>" + inertial + "</link>";
  for (int i = 0; i < links; ++i)
    xml += "<joint name='j" + std::to_string(i) + "' type='continuous'><parent link='l" +
           std::to_string(i) + "'/><child link='l" + std::to_string(i + 1) +
           "'/><axis xyz='0 0 1'/></joint>";
  return xml + "</robot>";
}

// A chain of 10^5 links is a legal URDF: it is imported without recursion (a recursion per
// link overflowed the stack at 10^4), its loop check is linear (a walk up from every link took
// O(n^2)), and its dense 10^5 x 10^5 mass matrix is refused by its size before allocation.
TEST(UrdfImport, LongChainIsImportedAndItsMassMatrixRefusedBySize) {
  ModelBuilder b;
  addUrdfString(b, chainUrdf(100000), "chain.urdf");
  EXPECT_EQ(b.bodyCount(), 100001);
  try {
    b.build();
    FAIL() << "a 10^5 x 10^5 dense mass matrix was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("the mass matrix of the tree rooted at body 'l0' (100000 "
                                         "degrees of freedom) needs about 320 GB of memory"),
              std::string::npos)
        << e.what();
  }
  ModelBuilder small;
  addUrdfString(small, chainUrdf(300), "chain.urdf");
  EXPECT_EQ(small.build().nv, 300);
}

// A '%' is legal in names; only the parse's messages are left unformatted.
TEST(UrdfImport, PercentInANameIsKept) {
  ModelBuilder b;
  addUrdfString(b,
                "<robot name='r%s'><link name='a%n'><inertial><mass value='1'/>"
                "<inertia ixx='1' ixy='0' ixz='0' iyy='1' iyz='0' izz='1'/></inertial></link>"
                "<link name='b'><inertial><mass value='1'/><inertia ixx='1' ixy='0' ixz='0' "
                "iyy='1' iyz='0' izz='1'/></inertial></link>"
                "<joint name='j%s' type='continuous'><parent link='a%n'/>"
                "<child link='b'/><axis xyz='0 0 1'/></joint></robot>",
                "percent.urdf");
  const Model m = b.build();
  EXPECT_EQ(m.nv, 1);
  EXPECT_GE(m.jointIndex("j%s"), 0);
}

TEST(UrdfImport, StringSourceIsNamedInErrors) {
  ModelBuilder b;
  try {
    addUrdfString(b, "<robot name='x'><link name='a'/>", "inline.urdf");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("inline.urdf"), std::string::npos);
  }
}

// urdfdom keeps a link's child joints in a map by name: children come in the order of their
// joints' names, not of the file (docs/conventions.md), and every entry of v has a name.
TEST(UrdfImport, ChildrenComeInTheOrderOfTheirJointNames) {
  const char* xml = R"(<robot name="r">
    <link name="base"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
    <link name="first"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
    <link name="second"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
    <joint name="z_joint" type="continuous"><parent link="base"/><child link="first"/><axis xyz="0 0 1"/></joint>
    <joint name="a_joint" type="continuous"><parent link="base"/><child link="second"/><axis xyz="0 0 1"/></joint>
  </robot>)";
  ModelBuilder builder("order.urdf");
  UrdfOptions options;
  options.floating_base = true;
  addUrdfString(builder, xml, "order.urdf", options);
  const Model model = builder.build();
  ASSERT_EQ(model.bodies.size(), 3u);
  EXPECT_EQ(model.bodies[1].name, "second");
  EXPECT_EQ(model.bodies[2].name, "first");
  const std::vector<std::string> expected = {"root_joint:vx", "root_joint:vy", "root_joint:vz",
                                             "root_joint:wx", "root_joint:wy", "root_joint:wz",
                                             "a_joint",       "z_joint"};
  EXPECT_EQ(model.dofNames(), expected);
  EXPECT_EQ(model.dofIndex("z_joint"), 7);
  EXPECT_THROW(model.dofIndex("y_joint"), InputError);
}

}  // namespace
}  // namespace sweep
