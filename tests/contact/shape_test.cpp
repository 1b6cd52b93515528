// Bad shapes and meshes are refused with a message naming the body and the shape.
#include "contact/shape.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "contact/contact_model.hpp"
#include "contact/convex_hull.hpp"
#include "contact/mesh_io.hpp"
#include "framework/error.hpp"
#include "framework/urdf_import.hpp"
#include "models/rigid_bodies.hpp"

namespace sweep {
namespace {

std::string dataPath(const std::string& name) {
  return std::string(SWEEP_TEST_DATA) + "/" + name;
}

// the message of the InputError that building a one-shape scene raises
std::string buildError(const Shape& shape) {
  ModelBuilder mb("bad shapes");
  addFreeBody(mb, "wheel", solidSphereInertia(1.0, 1.0));
  const Model model = mb.build();
  ContactModelBuilder cb(model);
  cb.addGeometry("rim", BodyRef::dynamic(0), Pose::identity(), shape);
  try {
    cb.build();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

void expectRefused(const Shape& shape, const std::string& what) {
  const std::string message = buildError(shape);
  EXPECT_NE(message.find("body 'wheel', shape 'rim'"), std::string::npos) << message;
  EXPECT_NE(message.find(what), std::string::npos) << message;
}

TEST(ShapeValidation, RadiusMustBePositive) {
  expectRefused(Shape::sphere(0.0), "radius must be > 0 and finite, got 0");
  expectRefused(Shape::sphere(-0.3e-3), "radius must be > 0 and finite, got -0.0003");
  expectRefused(Shape::cylinder(std::nan(""), 1.0), "radius must be > 0 and finite, got nan");
  expectRefused(Shape::capsule(0.1, -1.0), "length must be > 0");
}

TEST(ShapeValidation, DegenerateBox) {
  expectRefused(Shape::box(Vector3(1.0, 0.0, 1.0)), "size.y must be > 0");
}

TEST(ShapeValidation, Polygons) {
  expectRefused(Shape::polygon({{0, 0}, {1, 0}}), "at least 3 vertices");
  expectRefused(Shape::polygon({{0, 0}, {0, 1}, {1, 0}}), "counter-clockwise");
  expectRefused(Shape::polygon({{0, 0}, {2, 0}, {1, 0.2}, {2, 2}, {0, 2}}), "convex");
  expectRefused(Shape::segment({0, 0}, {0, 0}), "length must be > 0");
}

TEST(ShapeValidation, Meshes) {
  expectRefused(Shape::triangleMesh(std::make_shared<TriangleMesh>()), "mesh is empty");
  expectRefused(Shape::triangleMesh(loadTriangleMesh(dataPath("meshes/non_manifold.stl"))),
                "non-manifold mesh");
  // a cube with one face removed is fine as a surface, not as a convex solid
  auto open_box = loadTriangleMesh(dataPath("meshes/cube.stl"));
  open_box->triangles.pop_back();
  EXPECT_EQ(buildError(Shape::triangleMesh(open_box)), "");
  expectRefused(Shape::convexMesh(open_box), "not closed");
  // a closed mesh is convex only when it winds outward and bends outward at every edge
  expectRefused(Shape::convexMesh(loadTriangleMesh(dataPath("meshes/dented_cube.stl"))),
                "convex mesh is not convex: at edge");
  EXPECT_EQ(buildError(Shape::triangleMesh(loadTriangleMesh(dataPath("meshes/dented_cube.stl")))),
            "");
  expectRefused(Shape::convexMesh(loadTriangleMesh(dataPath("meshes/inward_cube.stl"))),
                "convex mesh winds inward");
  expectRefused(Shape::triangleMesh(loadTriangleMesh(dataPath("meshes/collinear.stl"))),
                "has no area");
  // two cubes in one file: closed and convex at every edge, but two surfaces
  auto two = loadTriangleMesh(dataPath("meshes/cube.stl"));
  const int n = static_cast<int>(two->vertices.size());
  const std::size_t triangles = two->triangles.size();
  for (int i = 0; i < n; ++i) two->vertices.push_back(two->vertices[i] + Vector3(3, 0, 0));
  for (std::size_t t = 0; t < triangles; ++t)
    two->triangles.push_back(
        {two->triangles[t][0] + n, two->triangles[t][1] + n, two->triangles[t][2] + n});
  expectRefused(Shape::convexMesh(two), "V - E + F = 4");
}

// A node that mirrors its part (negative determinant) keeps it outward; one that scales an axis
// to 0 is refused, naming the node.
TEST(MeshIo, ColladaNodeTransformsMirrorOrAreRefused) {
  EXPECT_EQ(buildError(Shape::convexMesh(loadTriangleMesh(dataPath("meshes/mirrored_node.dae")))),
            "");
  try {
    loadTriangleMesh(dataPath("meshes/flattened_node.dae"));
    ADD_FAILURE() << "a node scaled to 0 was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("node 'flat': its transform flattens the mesh"),
              std::string::npos)
        << e.what();
  }
}

// COLLADA is read in ROS's frame: <unit> scales the file, <up_axis> Z_UP does not turn it. The
// KR5 package's visual (millimetres, Z_UP) and its collision STL (millimetres, which the URDF
// scales by 1e-3) hold one stand-in box; turned a quarter about x, their extents would differ.
TEST(MeshIo, ColladaKeepsItsZUpAndHonoursItsUnit) {
  const std::string folder = "packages/src/kuka_kr5_support/meshes/kr5_arc/";
  const auto visual = loadTriangleMesh(dataPath(folder + "visual/link_3.dae"));
  const auto collision =
      loadTriangleMesh(dataPath(folder + "collision/link_3.stl"), Vector3::Constant(1e-3));
  ASSERT_EQ(visual->vertices.size(), collision->vertices.size());
  auto extent = [](const TriangleMesh& mesh) {
    Eigen::AlignedBox3d box;
    for (const Vector3& p : mesh.vertices) box.extend(p);
    return box;
  };
  const Eigen::AlignedBox3d a = extent(*visual), b = extent(*collision);
  // the STL's float32 millimetres against the COLLADA's 9 digits
  EXPECT_LT((a.min() - b.min()).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_LT((a.max() - b.max()).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_GT(b.max().x(), 0.6);  // along the link, toward joint a4 at (0.62, -0.12, 0)
}

TEST(MeshIo, ReadsAsciiStlAndMergesVertices) {
  const auto cube = loadTriangleMesh(dataPath("meshes/cube.stl"), Vector3(2.0, 2.0, 2.0));
  EXPECT_EQ(cube->triangles.size(), 12u);
  EXPECT_EQ(cube->vertices.size(), 8u);
  for (const Vector3& p : cube->vertices) EXPECT_DOUBLE_EQ(p.cwiseAbs().maxCoeff(), 1.0);
  EXPECT_EQ(buildError(Shape::convexMesh(cube)), "");
  // facets with their own normals (a curved surface): still one vertex per position, so that
  // the bowl's only unshared edges are its rim's 16
  const auto bowl = Shape::triangleMesh(loadTriangleMesh(dataPath("meshes/bowl.stl"))).mesh;
  EXPECT_EQ(bowl->vertices.size(), 129u);
  int rim = 0, ridges = 0, valleys = 0;
  for (std::size_t t = 0; t < bowl->triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      rim += bowl->across[t][k] < 0;
      ridges += bowl->across[t][k] >= 0 && bowl->edge_kind[t][k] > 0;
      valleys += bowl->edge_kind[t][k] < 0;
    }
  EXPECT_EQ(rim, 16);
  EXPECT_EQ(ridges + valleys, 3 * 240 - 16);
  EXPECT_GT(valleys, ridges);  // a quad of a sphere split in two folds along its diagonal
}

TEST(MeshIo, MissingOrEmptyFileNamesTheFile) {
  try {
    loadTriangleMesh(dataPath("meshes/none.stl"));
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("meshes/none.stl: mesh file not found"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(loadTriangleMesh(dataPath("meshes/empty.stl")), InputError);
}

TEST(MeshIo, UrdfCollisionMeshMissing) {
  const Model model = loadUrdf(dataPath("urdf/bad/missing_mesh.urdf"));
  ContactModelBuilder cb(model);
  try {
    cb.addModelCollisions();
    FAIL();
  } catch (const InputError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("body 'arm'"), std::string::npos) << message;
    EXPECT_NE(message.find("no_such_file.stl: mesh file not found"), std::string::npos) << message;
  }
}

TEST(MeshIo, UrdfCollisionMeshLoaded) {
  const Model model = loadUrdf(dataPath("urdf/arm6.urdf"));
  ContactModelBuilder cb(model);
  cb.addModelCollisions();
  const ContactModel cmodel = cb.build();
  int meshes = 0;
  for (const Geometry& g : cmodel.geometries)
    if (g.shape.type == ShapeType::TriangleMesh) {
      ++meshes;
      // 300 x 40 x 40 mm bar scaled to metres
      EXPECT_NEAR(boundingRadius(g.shape), std::sqrt(0.3 * 0.3 + 2 * 0.02 * 0.02), 1e-12);
    }
  EXPECT_EQ(meshes, 1);
}

// Qhull's hull is closed, outward and convex; it takes a mesh that is not manifold (CAD
// exports often are not) and refuses vertices that span no volume, naming the mesh.
TEST(ConvexHull, ClosedOutwardAndConvexFromAnyVertexSet) {
  for (const char* file :
       {"meshes/dented_cube.stl", "meshes/non_manifold.stl", "meshes/bowl.stl"}) {
    SCOPED_TRACE(file);
    const auto mesh = loadTriangleMesh(dataPath(file));
    const auto hull = convexHull(*mesh, file);
    EXPECT_EQ(buildError(Shape::convexMesh(hull)), "");
    // every input vertex inside or on the hull
    const Shape solid = Shape::triangleMesh(hull);
    for (const Vector3& p : mesh->vertices)
      for (std::size_t t = 0; t < hull->triangles.size(); ++t)
        ASSERT_LE(solid.mesh->normals[t].dot(p - hull->vertices[hull->triangles[t][0]]), 1e-12);
  }
  const auto dented = convexHull(*loadTriangleMesh(dataPath("meshes/dented_cube.stl")), "dented");
  EXPECT_EQ(dented->vertices.size(), 8u);  // the dent's vertex is inside
  auto flat = std::make_shared<TriangleMesh>();
  flat->vertices = {Vector3(0, 0, 0), Vector3(1, 0, 0), Vector3(1, 1, 0), Vector3(0, 1, 0)};
  for (const auto& [mesh, cause] : {std::pair{flat, "span no volume"},
                                    std::pair{std::make_shared<TriangleMesh>(), "0 vertices"}}) {
    try {
      convexHull(*mesh, "link.stl");
      ADD_FAILURE() << "no error for " << cause;
    } catch (const InputError& e) {
      EXPECT_EQ(std::string(e.what()).rfind("link.stl: ", 0), 0u) << e.what();
      EXPECT_NE(std::string(e.what()).find(cause), std::string::npos) << e.what();
    }
  }
}

// A URDF link's mesh is its hull unless collision_meshes asks for its triangles, which must
// then be manifold.
TEST(MeshIo, UrdfCollisionMeshIsItsHullOrItsTriangles) {
  const std::string mesh = dataPath("meshes/non_manifold.stl");
  const std::string urdf =
      "<robot name='r'><link name='base'/><link name='arm'><inertial><mass value='1'/>"
      "<inertia ixx='1' ixy='0' ixz='0' iyy='1' iyz='0' izz='1'/></inertial><collision>"
      "<geometry><mesh filename='" +
      mesh +
      "'/></geometry></collision></link>"
      "<joint name='j' type='continuous'><parent link='base'/><child link='arm'/>"
      "<axis xyz='0 0 1'/></joint></robot>";
  for (const CollisionMeshes kind : {CollisionMeshes::ConvexHull, CollisionMeshes::Triangles}) {
    UrdfOptions options;
    options.collision_meshes = kind;
    ModelBuilder builder;
    addUrdfString(builder, urdf, "r.urdf", options);
    const Model model = builder.build();
    ContactModelBuilder cb(model);
    cb.addModelCollisions();
    if (kind == CollisionMeshes::ConvexHull) {
      const ContactModel cmodel = cb.build();
      ASSERT_EQ(cmodel.geometries.size(), 1u);
      EXPECT_EQ(cmodel.geometries[0].shape.type, ShapeType::TriangleMesh);
    } else {
      try {
        cb.build();
        ADD_FAILURE() << "a non-manifold mesh was taken as triangles";
      } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find("non-manifold mesh"), std::string::npos) << e.what();
      }
    }
  }
}

// The detection path is chosen by the pairs that can meet: a robot's mesh links never meet
// one another without self-collision, so a UR10 on a floor takes the analytic path; with
// self-collision, or a second robot, mesh meets mesh and the scene takes FCL's.
TEST(ContactModel, PairsThatCannotMeetDoNotChooseThePath) {
  const std::string packages = dataPath("packages/src");
  UrdfOptions options;
  options.package_paths = {packages};
  auto path = [&](int robots, bool self_collision) {
    ModelBuilder builder;
    for (int r = 0; r < robots; ++r) {
      options.name_prefix = "r" + std::to_string(r) + "_";
      options.base_placement.translation = Vector3(2.0 * r, 0, 0);
      addUrdf(builder, packages + "/ur_description/urdf/ur10_robot.urdf", options);
    }
    const Model model = builder.build();
    ContactModelBuilder cb(model);
    DetectionSettings settings;
    settings.self_collision = self_collision;
    cb.setSettings(settings);
    cb.addModelCollisions();
    cb.addGeometry("floor", BodyRef::world(), Pose::identity(), Shape::halfSpace());
    const ContactModel cmodel = cb.build();
    return std::pair{cmodel.path, cmodel.path_reason};
  };
  EXPECT_EQ(path(1, false).first, DetectionPath::Analytic) << path(1, false).second;
  for (const auto& [robots, self] : {std::pair{1, true}, std::pair{2, false}}) {
    const auto [chosen, reason] = path(robots, self);
    EXPECT_EQ(chosen, DetectionPath::Fcl) << robots << " robots, self-collision " << self;
    EXPECT_NE(reason.find("triangle mesh-triangle mesh"), std::string::npos) << reason;
  }
}

TEST(Materials, LawsAreValidated) {
  MaterialTable table;
  const int steel = table.add("steel");
  EXPECT_THROW(table.add("steel"), InputError);
  EXPECT_THROW(table.setLaw(steel, 0, {-0.1, 0.0}), InputError);
  EXPECT_THROW(table.setLaw(steel, 0, {0.3, 1.5}), InputError);
  table.setLaw(steel, 0, {0.3, 0.5});
  EXPECT_EQ(table.law(0, steel).friction, 0.3);
  EXPECT_EQ(table.law(steel, steel).friction, 0.0);
  EXPECT_EQ(table.id("steel"), steel);
  EXPECT_THROW(table.id("wood"), InputError);
}

// The broadphase's box about a large shape (contact/pair_search.cpp): it holds every point of
// the shape, and is tight, at any rotation. A long blade's bounding ball's cube held the whole
// powder bed.
TEST(BoundingHalfWidths, HoldEachShapeAndAreTight) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  auto randomUnit = [&] {
    Vector3 u;
    do u = Vector3(unit(rng), unit(rng), unit(rng));
    while (u.norm() < 0.1 || u.norm() > 1.0);
    return u.normalized();
  };
  const double r = 0.1, L = 2.0;
  const std::vector<Shape> shapes = {Shape::box(Vector3(0.05, 0.6, 4.0)), Shape::capsule(r, L),
                                     Shape::cylinder(r, L), Shape::sphere(r)};
  for (int turn = 0; turn < 20; ++turn) {
    const Matrix3 R =
        turn == 0 ? Matrix3::Identity() : Matrix3(Eigen::AngleAxisd(3.0 * unit(rng), randomUnit()));
    for (const Shape& shape : shapes) {
      const Vector3 half = boundingHalfWidths(shape, R);
      // points of the shape, in its frame: a box's corners, a capsule's rounded ends, a
      // cylinder's rims, a ball's surface
      std::vector<Vector3> points;
      for (int k = 0; k < 20000; ++k) {
        const Vector3 u = randomUnit();
        const double angle = 2.0 * M_PI * k / 20000.0, end = (k % 2 ? 0.5 : -0.5) * L;
        switch (shape.type) {
          case ShapeType::Box:
            if (k < 8)
              points.push_back(shape.half_extents.cwiseProduct(
                  Vector3(k & 1 ? 1.0 : -1.0, k & 2 ? 1.0 : -1.0, k & 4 ? 1.0 : -1.0)));
            break;
          case ShapeType::Capsule:
            points.push_back(Vector3(0.0, 0.0, end) + r * u);
            break;
          case ShapeType::Cylinder:
            points.push_back(Vector3(r * std::cos(angle), r * std::sin(angle), end));
            break;
          default:
            points.push_back(r * u);
        }
      }
      Vector3 reach = Vector3::Zero();
      for (const Vector3& p : points) reach = reach.cwiseMax((R * p).cwiseAbs());
      for (int i = 0; i < 3; ++i) {
        EXPECT_LE(reach[i], half[i] * (1.0 + 1e-12)) << "turn " << turn << ", axis " << i;
        EXPECT_GE(reach[i], 0.995 * half[i]) << "turn " << turn << ", axis " << i;
      }
      // never wider than the bounding ball's cube it replaces
      EXPECT_LE(half.maxCoeff(), boundingRadius(shape) * (1.0 + 1e-12));
    }
  }
}

}  // namespace
}  // namespace sweep
