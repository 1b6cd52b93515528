#include "contact/shape.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <sstream>

#include "framework/error.hpp"

namespace sweep {

const char* shapeTypeName(ShapeType type) {
  switch (type) {
    case ShapeType::Sphere:
      return "sphere";
    case ShapeType::Box:
      return "box";
    case ShapeType::Cylinder:
      return "cylinder";
    case ShapeType::Capsule:
      return "capsule";
    case ShapeType::ConvexMesh:
      return "convex mesh";
    case ShapeType::TriangleMesh:
      return "triangle mesh";
    case ShapeType::HalfSpace:
      return "half-space";
    case ShapeType::Disk:
      return "disk";
    case ShapeType::Segment:
      return "segment";
    case ShapeType::Polygon:
      return "polygon";
    case ShapeType::HalfPlane:
      return "half-plane";
  }
  return "unknown";
}

bool isPlanarShape(ShapeType type) {
  return type == ShapeType::Disk || type == ShapeType::Segment || type == ShapeType::Polygon ||
         type == ShapeType::HalfPlane;
}

Shape Shape::sphere(double radius) {
  Shape s;
  s.type = ShapeType::Sphere;
  s.radius = radius;
  return s;
}
Shape Shape::box(const Vector3& size) {
  Shape s;
  s.type = ShapeType::Box;
  s.half_extents = 0.5 * size;
  return s;
}
Shape Shape::cylinder(double radius, double length) {
  Shape s;
  s.type = ShapeType::Cylinder;
  s.radius = radius;
  s.length = length;
  return s;
}
Shape Shape::capsule(double radius, double length) {
  Shape s = cylinder(radius, length);
  s.type = ShapeType::Capsule;
  return s;
}
Shape Shape::convexMesh(std::shared_ptr<const TriangleMesh> mesh) {
  // the same surface and topology as a triangle mesh: the closed forms against balls, boxes
  // and capsules serve both
  Shape s = triangleMesh(std::move(mesh));
  s.type = ShapeType::ConvexMesh;
  return s;
}
void buildMeshTopology(TriangleMesh& mesh) {
  const int n = static_cast<int>(mesh.vertices.size());
  const int triangles = static_cast<int>(mesh.triangles.size());
  mesh.normals.assign(triangles, Vector3::UnitZ());
  mesh.across.assign(triangles, {-1, -1, -1});
  mesh.around_start.assign(n + 1, 0);
  std::map<std::pair<int, int>, std::pair<int, int>> edges;  // (low, high) -> (triangle, edge)
  for (int t = 0; t < triangles; ++t) {
    const auto& tri = mesh.triangles[t];
    bool inside = true;
    for (int k = 0; k < 3; ++k) inside = inside && tri[k] >= 0 && tri[k] < n;
    if (!inside) continue;  // validateShape names it
    const Vector3 normal = (mesh.vertices[tri[1]] - mesh.vertices[tri[0]])
                               .cross(mesh.vertices[tri[2]] - mesh.vertices[tri[0]]);
    if (normal.norm() > 0.0) mesh.normals[t] = normal.normalized();
    for (int k = 0; k < 3; ++k) {
      ++mesh.around_start[tri[k] + 1];
      const std::pair<int, int> key{std::min(tri[k], tri[(k + 1) % 3]),
                                    std::max(tri[k], tri[(k + 1) % 3])};
      const auto [it, fresh] = edges.emplace(key, std::pair<int, int>{t, k});
      if (fresh || mesh.across[it->second.first][it->second.second] >= 0) continue;
      mesh.across[it->second.first][it->second.second] = t;
      mesh.across[t][k] = it->second.first;
    }
  }
  for (int v = 0; v < n; ++v) mesh.around_start[v + 1] += mesh.around_start[v];
  mesh.around.assign(mesh.around_start[n], 0);
  std::vector<int> fill(mesh.around_start.begin(), mesh.around_start.end() - 1);
  for (int t = 0; t < triangles; ++t)
    for (int v : mesh.triangles[t])
      if (v >= 0 && v < n) mesh.around[fill[v]++] = t;
  // an edge bends by where the triangle across it puts its third vertex: behind this
  // triangle's plane (convex), in it (flat, to 1e-9 of the distance) or in front (concave)
  mesh.edge_kind.assign(triangles, {1, 1, 1});
  for (int t = 0; t < triangles; ++t)
    for (int k = 0; k < 3; ++k) {
      const int other = mesh.across[t][k];
      if (other < 0) continue;
      const auto& o = mesh.triangles[other];
      const int v0 = mesh.triangles[t][k], v1 = mesh.triangles[t][(k + 1) % 3];
      int third = o[0];
      for (int v : o)
        if (v != v0 && v != v1) third = v;
      const Vector3 w = mesh.vertices[third] - mesh.vertices[v0];
      const double side = mesh.normals[t].dot(w);
      mesh.edge_kind[t][k] = side < -1e-9 * w.norm() ? 1 : (side > 1e-9 * w.norm() ? -1 : 0);
    }
  std::vector<signed char> lowest(n, 1), highest(n, -1);
  for (int t = 0; t < triangles; ++t)
    for (int k = 0; k < 3; ++k)
      for (int v : {mesh.triangles[t][k], mesh.triangles[t][(k + 1) % 3]}) {
        if (v < 0 || v >= n) continue;
        lowest[v] = std::min(lowest[v], mesh.edge_kind[t][k]);
        highest[v] = std::max(highest[v], mesh.edge_kind[t][k]);
      }
  mesh.vertex_convex.assign(n, 0);
  for (int v = 0; v < n; ++v) mesh.vertex_convex[v] = lowest[v] >= 0 && highest[v] > 0;
  buildTriangleTree(mesh);
}

void buildTriangleTree(TriangleMesh& mesh) {
  const int n = static_cast<int>(mesh.vertices.size());
  mesh.tree.clear();
  mesh.tree_triangles.clear();
  std::vector<Vector3> centre;
  for (int t = 0; t < static_cast<int>(mesh.triangles.size()); ++t) {
    const auto& tri = mesh.triangles[t];
    if (tri[0] < 0 || tri[0] >= n || tri[1] < 0 || tri[1] >= n || tri[2] < 0 || tri[2] >= n)
      continue;  // validateShape names it
    if (!mesh.vertices[tri[0]].allFinite() || !mesh.vertices[tri[1]].allFinite() ||
        !mesh.vertices[tri[2]].allFinite())
      continue;  // and this: a non-finite centre would break the median's order
    mesh.tree_triangles.push_back(t);
    centre.push_back((mesh.vertices[tri[0]] + mesh.vertices[tri[1]] + mesh.vertices[tri[2]]) / 3);
  }
  if (mesh.tree_triangles.empty()) return;
  std::vector<Vector3> triangle_centre(mesh.triangles.size(), Vector3::Zero());
  for (std::size_t k = 0; k < centre.size(); ++k)
    triangle_centre[mesh.tree_triangles[k]] = centre[k];
  constexpr int kLeaf = 4;
  // top down: a node's triangles split at the median of their centres along its longest side;
  // the tree's depth stays within forEachTriangleIn's stack (2 log2(triangles / kLeaf))
  mesh.tree.push_back({});
  mesh.tree[0].end = static_cast<int>(mesh.tree_triangles.size());
  for (std::size_t k = 0; k < mesh.tree.size(); ++k) {
    const int begin = mesh.tree[k].begin, end = mesh.tree[k].end;
    Vector3 lower = Vector3::Constant(std::numeric_limits<double>::infinity()), upper = -lower;
    Vector3 centre_lower = lower, centre_upper = upper;
    for (int i = begin; i < end; ++i) {
      const int t = mesh.tree_triangles[i];
      for (int v : mesh.triangles[t]) {
        lower = lower.cwiseMin(mesh.vertices[v]);
        upper = upper.cwiseMax(mesh.vertices[v]);
      }
      centre_lower = centre_lower.cwiseMin(triangle_centre[t]);
      centre_upper = centre_upper.cwiseMax(triangle_centre[t]);
    }
    mesh.tree[k].lower = lower;
    mesh.tree[k].upper = upper;
    if (end - begin <= kLeaf) continue;
    int axis = 0;
    (centre_upper - centre_lower).maxCoeff(&axis);
    const int middle = begin + (end - begin) / 2;
    std::nth_element(mesh.tree_triangles.begin() + begin, mesh.tree_triangles.begin() + middle,
                     mesh.tree_triangles.begin() + end, [&](int a, int b) {
                       const double ca = triangle_centre[a][axis], cb = triangle_centre[b][axis];
                       return ca < cb || (ca == cb && a < b);
                     });
    const int child = static_cast<int>(mesh.tree.size());
    mesh.tree[k].first_child = child;
    TriangleMesh::TreeNode left, right;
    left.begin = begin;
    left.end = middle;
    right.begin = middle;
    right.end = end;
    mesh.tree.push_back(left);
    mesh.tree.push_back(right);
  }
}

std::shared_ptr<const TriangleMesh> closedBoxMesh(const Vector3& half_extents) {
  auto mesh = std::make_shared<TriangleMesh>();
  for (int k = 0; k < 8; ++k)
    mesh->vertices.emplace_back((k & 1) ? half_extents.x() : -half_extents.x(),
                                (k & 2) ? half_extents.y() : -half_extents.y(),
                                (k & 4) ? half_extents.z() : -half_extents.z());
  mesh->triangles = {{4, 5, 7}, {4, 7, 6}, {0, 2, 3}, {0, 3, 1}, {0, 1, 5}, {0, 5, 4},
                     {2, 6, 7}, {2, 7, 3}, {0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}};
  buildMeshTopology(*mesh);
  return mesh;
}

Shape Shape::triangleMesh(std::shared_ptr<const TriangleMesh> mesh) {
  Shape s;
  s.type = ShapeType::TriangleMesh;
  // the closed forms read the topology and the tree: a mesh without them gets them here
  if (mesh && (mesh->normals.size() != mesh->triangles.size() ||
               mesh->edge_kind.size() != mesh->triangles.size() ||
               mesh->vertex_convex.size() != mesh->vertices.size() ||
               (mesh->tree.empty() && !mesh->triangles.empty()))) {
    auto with_topology = std::make_shared<TriangleMesh>(*mesh);
    buildMeshTopology(*with_topology);
    mesh = std::move(with_topology);
  }
  if (mesh) s.vertices = mesh->vertices;
  s.mesh = std::move(mesh);
  return s;
}
Shape Shape::halfSpace() {
  Shape s;
  s.type = ShapeType::HalfSpace;
  return s;
}
Shape Shape::disk(double radius) {
  Shape s = sphere(radius);
  s.type = ShapeType::Disk;
  return s;
}
Shape Shape::segment(const Vector2& start, const Vector2& end, double rounding) {
  Shape s;
  s.type = ShapeType::Segment;
  s.segment_start = Vector3(start.x(), start.y(), 0.0);
  s.segment_end = Vector3(end.x(), end.y(), 0.0);
  s.radius = rounding;
  return s;
}
Shape Shape::polygon(const std::vector<Vector2>& counter_clockwise_vertices) {
  Shape s;
  s.type = ShapeType::Polygon;
  for (const Vector2& p : counter_clockwise_vertices) s.vertices.emplace_back(p.x(), p.y(), 0.0);
  return s;
}
Shape Shape::halfPlane() {
  Shape s;
  s.type = ShapeType::HalfPlane;
  return s;
}

namespace {

[[noreturn]] void reject(const std::string& owner, const Shape& shape, const std::string& what) {
  throw InputError(owner + " (" + shapeTypeName(shape.type) + "): " + what);
}

std::string show(double value) {
  std::ostringstream out;
  out.precision(9);
  out << value;
  return out.str();
}

void requirePositive(const std::string& owner, const Shape& shape, const char* field,
                     double value) {
  if (!(std::isfinite(value) && value > 0.0))
    reject(owner, shape, std::string(field) + " must be > 0 and finite, got " + show(value));
}

// A closed mesh bounds a convex solid when its triangles wind one way (each edge runs once in
// each direction), outward (positive volume), form one sphere-like surface (V - E + F = 2) and
// every edge is convex: a locally convex closed surface is convex (Hadamard). Tolerance 1e-6 of
// the mesh's size, for vertices stored in single precision (STL).
void requireConvex(const std::string& owner, const Shape& shape, std::size_t edge_count) {
  const TriangleMesh& mesh = *shape.mesh;
  std::map<std::pair<int, int>, int> directed;  // (from, to) -> triangle
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const std::pair<int, int> edge{mesh.triangles[t][k], mesh.triangles[t][(k + 1) % 3]};
      const auto [it, fresh] = directed.emplace(edge, static_cast<int>(t));
      if (!fresh)
        reject(owner, shape,
               "convex mesh is not wound one way: edge " + std::to_string(edge.first) + " -> " +
                   std::to_string(edge.second) + " runs the same way in triangles " +
                   std::to_string(it->second) + " and " + std::to_string(t));
    }
  std::vector<bool> used(mesh.vertices.size(), false);
  Vector3 low = Vector3::Constant(std::numeric_limits<double>::infinity()), high = -low;
  double volume6 = 0.0;
  for (const auto& tri : mesh.triangles) {
    const Vector3 &a = mesh.vertices[tri[0]], &b = mesh.vertices[tri[1]],
                  &c = mesh.vertices[tri[2]];
    volume6 += a.dot(b.cross(c));
    for (int k = 0; k < 3; ++k) {
      used[tri[k]] = true;
      low = low.cwiseMin(mesh.vertices[tri[k]]);
      high = high.cwiseMax(mesh.vertices[tri[k]]);
    }
  }
  if (!(volume6 > 0.0))
    reject(owner, shape,
           "convex mesh winds inward (its enclosed volume is " + show(volume6 / 6.0) +
               "): its triangles must run counter-clockwise seen from outside");
  const long euler = static_cast<long>(std::count(used.begin(), used.end(), true)) -
                     static_cast<long>(edge_count) + static_cast<long>(mesh.triangles.size());
  if (euler != 2)
    reject(owner, shape,
           "convex mesh is not one closed surface without holes (V - E + F = " +
               std::to_string(euler) + ", a convex surface has 2)");
  const double tolerance = 1e-6 * (high - low).norm();
  for (const auto& [edge, t] : directed) {
    const int u = directed.at({edge.second, edge.first});
    const auto& tri = mesh.triangles[t];
    const Vector3 &a = mesh.vertices[tri[0]], &b = mesh.vertices[tri[1]],
                  &c = mesh.vertices[tri[2]];
    const Vector3 normal = (b - a).cross(c - a).normalized();
    int across = -1;  // the corner of the neighbour off the shared edge
    for (int k = 0; k < 3; ++k)
      if (mesh.triangles[u][k] != edge.first && mesh.triangles[u][k] != edge.second)
        across = mesh.triangles[u][k];
    const double above = normal.dot(mesh.vertices[across] - a);
    if (above > tolerance)
      reject(owner, shape,
             "convex mesh is not convex: at edge (" + std::to_string(edge.first) + ", " +
                 std::to_string(edge.second) + ") vertex " + std::to_string(across) + " lies " +
                 show(above) + " above the plane of triangle " + std::to_string(t) +
                 "; use convex: false for a concave mesh");
  }
}

void validateMesh(const std::string& owner, const Shape& shape, bool closed) {
  if (!shape.mesh || shape.mesh->vertices.empty() || shape.mesh->triangles.empty())
    reject(owner, shape, "mesh is empty");
  const TriangleMesh& mesh = *shape.mesh;
  const int n = static_cast<int>(mesh.vertices.size());
  for (int i = 0; i < n; ++i)
    if (!mesh.vertices[i].allFinite())
      reject(owner, shape, "vertex " + std::to_string(i) + " is not finite");
  // an edge shared by more than two triangles has no inside and outside
  std::map<std::pair<int, int>, int> edge_use;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    for (int k = 0; k < 3; ++k) {
      if (tri[k] < 0 || tri[k] >= n)
        reject(owner, shape,
               "triangle " + std::to_string(t) + " uses vertex " + std::to_string(tri[k]) + " of " +
                   std::to_string(n));
      const int a = tri[k], b = tri[(k + 1) % 3];
      if (a == b)
        reject(owner, shape,
               "triangle " + std::to_string(t) + " repeats vertex " + std::to_string(a));
      ++edge_use[{std::min(a, b), std::max(a, b)}];
    }
  }
  // a triangle without area has no normal; collinear to 1e-12 of its longest edge squared
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const auto& tri = mesh.triangles[t];
    const Vector3 &a = mesh.vertices[tri[0]], &b = mesh.vertices[tri[1]],
                  &c = mesh.vertices[tri[2]];
    const double longest =
        std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()});
    if (!((b - a).cross(c - a).norm() > 1e-12 * longest))
      reject(owner, shape,
             "triangle " + std::to_string(t) + " (vertices " + std::to_string(tri[0]) + ", " +
                 std::to_string(tri[1]) + ", " + std::to_string(tri[2]) +
                 ") has no area: its corners are on one line");
  }
  for (const auto& [edge, count] : edge_use) {
    if (count > 2)
      reject(owner, shape,
             "non-manifold mesh: edge (" + std::to_string(edge.first) + ", " +
                 std::to_string(edge.second) + ") is shared by " + std::to_string(count) +
                 " triangles");
    if (closed && count != 2)
      reject(owner, shape,
             "convex mesh is not closed: edge (" + std::to_string(edge.first) + ", " +
                 std::to_string(edge.second) + ") borders one triangle");
  }
  if (closed) requireConvex(owner, shape, edge_use.size());
}

}  // namespace

void validateShape(const Shape& shape, const std::string& owner) {
  switch (shape.type) {
    case ShapeType::Sphere:
    case ShapeType::Disk:
      requirePositive(owner, shape, "radius", shape.radius);
      break;
    case ShapeType::Box:
      for (int k = 0; k < 3; ++k)
        requirePositive(owner, shape, k == 0 ? "size.x" : (k == 1 ? "size.y" : "size.z"),
                        2.0 * shape.half_extents[k]);
      break;
    case ShapeType::Cylinder:
    case ShapeType::Capsule:
      requirePositive(owner, shape, "radius", shape.radius);
      if (shape.type == ShapeType::Cylinder || shape.length != 0.0)
        requirePositive(owner, shape, "length", shape.length);
      break;
    case ShapeType::ConvexMesh:
      validateMesh(owner, shape, true);
      break;
    case ShapeType::TriangleMesh:
      validateMesh(owner, shape, false);
      break;
    case ShapeType::Segment: {
      if (!shape.segment_start.allFinite() || !shape.segment_end.allFinite())
        reject(owner, shape, "end points must be finite");
      const double length = (shape.segment_end - shape.segment_start).norm();
      requirePositive(owner, shape, "length", length);
      if (!(std::isfinite(shape.radius) && shape.radius >= 0.0))
        reject(owner, shape, "rounding radius must be >= 0, got " + show(shape.radius));
      break;
    }
    case ShapeType::Polygon: {
      const std::size_t n = shape.vertices.size();
      if (n < 3) reject(owner, shape, "needs at least 3 vertices, got " + std::to_string(n));
      for (std::size_t i = 0; i < n; ++i) {
        if (!shape.vertices[i].allFinite())
          reject(owner, shape, "vertex " + std::to_string(i) + " is not finite");
        const Vector3 e0 = shape.vertices[(i + 1) % n] - shape.vertices[i];
        const Vector3 e1 = shape.vertices[(i + 2) % n] - shape.vertices[(i + 1) % n];
        const double turn = e0.x() * e1.y() - e0.y() * e1.x();
        if (!(turn > 0.0))
          reject(owner, shape,
                 "vertices must form a convex polygon in counter-clockwise order; the turn at "
                 "vertex " +
                     std::to_string((i + 1) % n) + " is " + show(turn));
      }
      // every turn to the left is not enough: a pentagram, or a polygon listed twice, turns
      // left at each vertex but winds around its centre twice
      double winding = 0.0;
      for (std::size_t i = 0; i < n; ++i) {
        const Vector3 e0 = shape.vertices[(i + 1) % n] - shape.vertices[i];
        const Vector3 e1 = shape.vertices[(i + 2) % n] - shape.vertices[(i + 1) % n];
        winding += std::atan2(e0.x() * e1.y() - e0.y() * e1.x(), e0.x() * e1.x() + e0.y() * e1.y());
      }
      const double turns = winding / (2.0 * M_PI);
      if (!(std::abs(turns - 1.0) < 1e-6))
        reject(owner, shape,
               "vertices must go once around a convex polygon; they go around " + show(turns) +
                   " times (a star, or a polygon listed twice?)");
      break;
    }
    case ShapeType::HalfSpace:
    case ShapeType::HalfPlane:
      break;
  }
}

Vector3 boundingHalfWidths(const Shape& shape, const Matrix3& rotation) {
  // capsules and cylinders lie along their local z axis
  const Vector3 axis = rotation.col(2).cwiseAbs();
  switch (shape.type) {
    case ShapeType::Sphere:
    case ShapeType::Disk:
      return Vector3::Constant(shape.radius);
    case ShapeType::Box:  // the corner furthest along each world axis
      return rotation.cwiseAbs() * shape.half_extents;
    case ShapeType::Capsule:  // the segment's ends, rounded
      return 0.5 * shape.length * axis + Vector3::Constant(shape.radius);
    case ShapeType::Cylinder: {  // the ends' rims: a circle of radius r reaches r sqrt(1 - a_i^2)
      const Vector3 across = (Vector3::Ones() - axis.cwiseAbs2()).cwiseMax(0.0).cwiseSqrt();
      return 0.5 * shape.length * axis + shape.radius * across;
    }
    default:
      return Vector3::Constant(boundingRadius(shape));
  }
}

double boundingRadius(const Shape& shape) {
  switch (shape.type) {
    case ShapeType::Sphere:
    case ShapeType::Disk:
      return shape.radius;
    case ShapeType::Box:
      return shape.half_extents.norm();
    case ShapeType::Cylinder:
      return std::hypot(shape.radius, 0.5 * shape.length);
    case ShapeType::Capsule:
      return shape.radius + 0.5 * shape.length;
    case ShapeType::Segment:
      return shape.radius + std::max(shape.segment_start.norm(), shape.segment_end.norm());
    case ShapeType::ConvexMesh:
    case ShapeType::TriangleMesh:
    case ShapeType::Polygon: {
      double r = 0.0;
      for (const Vector3& p : shape.vertices) r = std::max(r, p.norm());
      return r;
    }
    case ShapeType::HalfSpace:
    case ShapeType::HalfPlane:
      return std::numeric_limits<double>::infinity();
  }
  return 0.0;
}

namespace {
Vector3 unitOr(const Vector3& d, const Vector3& fallback) {
  const double n = d.norm();
  return n > 0.0 ? Vector3(d / n) : fallback;
}
double signOf(double x) {
  return x < 0.0 ? -1.0 : 1.0;
}
}  // namespace

Vector3 supportPoint(const Shape& shape, const Vector3& direction) {
  switch (shape.type) {
    case ShapeType::Sphere:
      return shape.radius * unitOr(direction, Vector3::UnitX());
    case ShapeType::Disk:
      return shape.radius * unitOr(Vector3(direction.x(), direction.y(), 0.0), Vector3::UnitX());
    case ShapeType::Box:
      return Vector3(signOf(direction.x()) * shape.half_extents.x(),
                     signOf(direction.y()) * shape.half_extents.y(),
                     signOf(direction.z()) * shape.half_extents.z());
    case ShapeType::Cylinder:
      return shape.radius * unitOr(Vector3(direction.x(), direction.y(), 0.0), Vector3::UnitX()) +
             Vector3(0, 0, signOf(direction.z()) * 0.5 * shape.length);
    case ShapeType::Capsule:
      return shape.radius * unitOr(direction, Vector3::UnitX()) +
             Vector3(0, 0, signOf(direction.z()) * 0.5 * shape.length);
    case ShapeType::Segment: {
      const Vector3& end = direction.dot(shape.segment_end - shape.segment_start) > 0.0
                               ? shape.segment_end
                               : shape.segment_start;
      return end +
             shape.radius * unitOr(Vector3(direction.x(), direction.y(), 0.0), Vector3::UnitX());
    }
    case ShapeType::Polygon:
    case ShapeType::ConvexMesh:
    case ShapeType::TriangleMesh: {
      Vector3 best = shape.vertices.front();
      double best_dot = best.dot(direction);
      for (const Vector3& p : shape.vertices) {
        const double d = p.dot(direction);
        if (d > best_dot) {
          best_dot = d;
          best = p;
        }
      }
      return best;
    }
    case ShapeType::HalfSpace:
    case ShapeType::HalfPlane:
      break;
  }
  throw std::logic_error("supportPoint: unbounded shape");
}

}  // namespace sweep
