#pragma once
// Collision shapes, each in its own local frame. 3D shapes follow FCL's conventions (box
// centred, cylinder and capsule along local z); 2D shapes live in the local xy plane of a
// planar body, whose z axis is the scene normal.
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "framework/spatial.hpp"

namespace sweep {

enum class ShapeType {
  // 3D
  Sphere,
  Box,
  Cylinder,
  Capsule,
  ConvexMesh,
  TriangleMesh,
  HalfSpace,  // solid z <= 0, outward normal +z
  // 2D, in the xy plane
  Disk,
  Segment,    // from segment_start to segment_end, rounded by `radius` (may be 0)
  Polygon,    // convex, counter-clockwise vertices
  HalfPlane,  // solid y <= 0, outward normal +y
};

const char* shapeTypeName(ShapeType type);
bool isPlanarShape(ShapeType type);

struct TriangleMesh {
  std::vector<Vector3> vertices;
  std::vector<std::array<int, 3>> triangles;
  // Topology for the closed forms against a non-convex mesh (Shape::triangleMesh fills it):
  // per triangle its unit normal (counter-clockwise: the front), the triangle across each edge
  // (k, k+1) or -1, and per vertex the triangles around it (CSR: around_start has one entry
  // per vertex and one more).
  std::vector<Vector3> normals;
  std::vector<std::array<int, 3>> across;
  std::vector<int> around_start, around;
  // Per edge (k, k+1) of each triangle: +1 convex (a ridge, or a boundary: a rim), 0 flat, -1
  // concave (a valley); per vertex: whether it can poke into a flat face (no concave edge
  // around it, and at least one convex one). Closed forms against boxes and capsules use them.
  std::vector<std::array<signed char, 3>> edge_kind;
  std::vector<char> vertex_convex;
  // A tree of boxes over the triangles: node 0 the root, each node two children or a leaf's
  // range of tree_triangles. The closed forms visit only the triangles near a shape.
  struct TreeNode {
    Vector3 lower = Vector3::Zero(), upper = Vector3::Zero();
    int first_child = -1;  // the other is first_child + 1; -1: a leaf
    int begin = 0, end = 0;
  };
  std::vector<TreeNode> tree;
  std::vector<int> tree_triangles;

  // f(t) for every triangle whose box meets [lower, upper] (mesh frame), each once.
  template <class F>
  void forEachTriangleIn(const Vector3& lower, const Vector3& upper, F&& f) const {
    if (tree.empty()) return;
    int stack[128];  // a median split's depth is about log2(triangles)
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const TreeNode& node = tree[stack[--top]];
      if ((node.lower.array() > upper.array()).any() || (node.upper.array() < lower.array()).any())
        continue;
      if (node.first_child < 0) {
        for (int k = node.begin; k < node.end; ++k) f(tree_triangles[k]);
      } else if (top + 2 <= 128) {
        stack[top++] = node.first_child + 1;
        stack[top++] = node.first_child;
      }
    }
  }
};

// Fills normals, across and around (a non-manifold edge keeps its first neighbour), the edge
// and vertex kinds, and the tree (buildTriangleTree).
void buildMeshTopology(TriangleMesh& mesh);
void buildTriangleTree(TriangleMesh& mesh);

// A box's surface as a closed triangle mesh with its topology (12 triangles, front outward):
// the mesh closed forms then take box-box and box-capsule pairs (narrowphase_mesh.hpp).
std::shared_ptr<const TriangleMesh> closedBoxMesh(const Vector3& half_extents);

struct Shape {
  ShapeType type = ShapeType::Sphere;
  double radius = 0.0;
  double length = 0.0;                     // cylinder, capsule
  Vector3 half_extents = Vector3::Zero();  // box
  Vector3 segment_start = Vector3::Zero();
  Vector3 segment_end = Vector3::Zero();
  std::vector<Vector3> vertices;             // polygon (z = 0) and convex mesh
  std::shared_ptr<const TriangleMesh> mesh;  // convex and triangle meshes; a box's surface

  static Shape sphere(double radius);
  static Shape box(const Vector3& size);  // full edge lengths
  static Shape cylinder(double radius, double length);
  static Shape capsule(double radius, double length);
  static Shape convexMesh(std::shared_ptr<const TriangleMesh> mesh);
  static Shape triangleMesh(std::shared_ptr<const TriangleMesh> mesh);
  static Shape halfSpace();
  static Shape disk(double radius);
  static Shape segment(const Vector2& start, const Vector2& end, double rounding = 0.0);
  static Shape polygon(const std::vector<Vector2>& counter_clockwise_vertices);
  static Shape halfPlane();
};

// Throws InputError naming `owner` (e.g. "body 'wheel', shape 'rim'") when the shape cannot be
// used: non-positive or non-finite sizes, a degenerate segment, a non-convex or clockwise
// polygon, an empty mesh or one with an edge shared by more than two triangles.
void validateShape(const Shape& shape, const std::string& owner);

// Radius of a ball about the local origin containing the shape; +inf for half-spaces.
double boundingRadius(const Shape& shape);
// Half-widths of a box along the world axes, about the local origin, that contains the shape
// turned by `rotation`: exact for balls, boxes, capsules and cylinders (a long blade's is thin
// across, where its bounding ball's cube held the whole bed), the bounding ball's cube for the
// others; +inf for half-spaces.
Vector3 boundingHalfWidths(const Shape& shape, const Matrix3& rotation);
inline bool isUnbounded(const Shape& shape) {
  return shape.type == ShapeType::HalfSpace || shape.type == ShapeType::HalfPlane;
}

// The point of a convex shape farthest along `direction` (local frame). Used for half-space
// contacts, where it gives exact gaps for every convex shape.
Vector3 supportPoint(const Shape& shape, const Vector3& direction);

}  // namespace sweep
