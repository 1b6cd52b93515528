// Bad shapes and meshes are refused with a message naming the body and the shape.
#include "contact/shape.hpp"

#include <gtest/gtest.h>

#include "contact/contact_model.hpp"
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

}  // namespace
}  // namespace sweep
