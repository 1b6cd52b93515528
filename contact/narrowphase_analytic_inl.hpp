#pragma once
// Template part of narrowphase_analytic.hpp.
#include <algorithm>
#include <array>
#include <cmath>

namespace sweep {

namespace detail {
template <class Emit>
void emitIfClose(const Vector3& origin, const Vector3& outward, const Vector3& deepest,
                 double rounding, double margin, int feature, Emit& emit) {
  const double gap = (deepest - origin).dot(outward) - rounding;
  if (gap >= margin) return;
  ContactPoint c;
  c.gap = gap;
  c.normal = outward;
  c.point_b = deepest - rounding * outward;
  c.point_a = c.point_b - gap * outward;
  c.feature = feature;
  emit(c);
}
// The point of triangle (a, b, c) closest to x (Ericson, Real-Time Collision Detection 5.1.5)
// and its feature there: 0 the face, 1 + k the edge (k, k+1), 4 + k the vertex k.
inline Vector3 closestOnTriangle(const Vector3& x, const Vector3& a, const Vector3& b,
                                 const Vector3& c, int& feature) {
  const Vector3 ab = b - a, ac = c - a, ap = x - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return feature = 4, a;
  const Vector3 bp = x - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return feature = 5, b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return feature = 1, a + d1 / (d1 - d3) * ab;
  const Vector3 cp = x - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return feature = 6, c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return feature = 3, a + d2 / (d2 - d6) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0)
    return feature = 2, b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b);
  const double denominator = 1.0 / (va + vb + vc);
  return feature = 0, a + ab * (vb * denominator) + ac * (vc * denominator);
}

// The feature of triangle t closest to x, as closestOnTriangle numbers it.
inline int closestFeature(const TriangleMesh& mesh, int t, const Vector3& x) {
  const auto& tri = mesh.triangles[t];
  int feature = 0;
  closestOnTriangle(x, mesh.vertices[tri[0]], mesh.vertices[tri[1]], mesh.vertices[tri[2]],
                    feature);
  return feature;
}

// Parameters of the closest points of the lines p1 + s d1 and p2 + t d2; false when parallel.
inline bool closestOnLines(const Vector3& p1, const Vector3& d1, const Vector3& p2,
                           const Vector3& d2, double& s, double& t) {
  const Vector3 r = p1 - p2;
  const double a = d1.dot(d1), e = d2.dot(d2), b = d1.dot(d2), c = d1.dot(r), f = d2.dot(r);
  const double denominator = a * e - b * b;
  if (!(denominator > 1e-12 * a * e)) return false;
  s = (b * f - c * e) / denominator;
  t = (a * f - b * c) / denominator;
  return true;
}

// Whether the solid behind triangles t and u is their half-spaces' intersection near both (a
// ridge, a rim, a slab's two sides; coplanar counts): each lies behind or on the other's plane.
inline bool mutuallyConvex(const TriangleMesh& mesh, int t, int u) {
  auto behind = [&](int of, int plane) {
    const Vector3& origin = mesh.vertices[mesh.triangles[plane][0]];
    for (int v : mesh.triangles[of]) {
      const Vector3 w = mesh.vertices[v] - origin;
      if (mesh.normals[plane].dot(w) > 1e-9 * w.norm()) return false;
    }
    return true;
  };
  return behind(t, u) && behind(u, t);
}

}  // namespace detail

template <class Emit>
void meshBall(const Pose& pose, const TriangleMesh& mesh, const Vector3& center, double radius,
              double margin, Emit&& emit) {
  meshPoint(pose, mesh, center, radius, radius, margin, emit);
}

template <class Emit>
void meshPoint(const Pose& pose, const TriangleMesh& mesh, const Vector3& center, double radius,
               double depth, double margin, Emit&& emit) {
  const Vector3 x = pose.rotation.transpose() * (center - pose.translation);  // mesh frame
  const int triangles = static_cast<int>(mesh.triangles.size());
  const double reach = radius + margin;
  // A point behind faces is pushed out through each, except through a face of a convex
  // junction (a rim, a slab's far side) where a shallower one leaves the solid: held here.
  constexpr int kHeld = 8;
  std::array<ContactPoint, kHeld> behind;
  std::array<int, kHeld> behind_triangle{};
  int behind_count = 0;
  const Vector3 box = Vector3::Constant(std::max(reach, depth));
  mesh.forEachTriangleIn(x - box, x + box, [&](int t) {
    const auto& tri = mesh.triangles[t];
    const Vector3 &a = mesh.vertices[tri[0]], &b = mesh.vertices[tri[1]],
                  &c = mesh.vertices[tri[2]];
    const Vector3& n = mesh.normals[t];
    const double side = n.dot(x - a);
    if (side > reach || side < -depth) return;  // beyond the margin, or behind the surface
    int feature = 0;
    const Vector3 p = detail::closestOnTriangle(x, a, b, c, feature);
    const Vector3 d = x - p;
    const double distance = d.norm();
    if ((feature == 0 ? side : distance) - radius >= margin) return;  // a point's side is signed
    Vector3 normal = n;
    double gap = side - radius;
    int id = t;
    if (feature != 0) {
      if (side < 0.0) return;  // behind this triangle, off its face: another one holds it
      // an edge or vertex counts once, where every triangle holding it finds it closest
      if (feature <= 3) {
        const int k = feature - 1;
        const int other = mesh.across[t][k];
        if (other >= 0) {
          if (other < t) return;  // the lower triangle emits it
          const int v0 = tri[k], v1 = tri[(k + 1) % 3];
          const int f = detail::closestFeature(mesh, other, x);
          const auto& o = mesh.triangles[other];
          bool same = false;  // the other triangle's closest feature is this edge
          for (int m = 0; m < 3; ++m)
            same = same || (f == 1 + m && ((o[m] == v0 && o[(m + 1) % 3] == v1) ||
                                           (o[m] == v1 && o[(m + 1) % 3] == v0)));
          if (!same) return;
        }
        id = triangles + 3 * t + k;
      } else {
        const int v = tri[feature - 4];
        bool lowest = true, closest = true;
        for (int j = mesh.around_start[v]; j < mesh.around_start[v + 1] && closest; ++j) {
          const int u = mesh.around[j];
          lowest = lowest && u >= t;
          const int f = detail::closestFeature(mesh, u, x);
          closest = f >= 4 && mesh.triangles[u][f - 4] == v;
        }
        if (!lowest || !closest) return;
        id = 4 * triangles + v;
      }
      if (distance > 1e-12 * std::max(radius, depth)) {
        normal = d / distance;
        gap = distance - radius;
      }
    }
    ContactPoint contact;
    contact.gap = gap;
    contact.normal = pose.rotation * normal;
    contact.point_a = pose.apply(p);
    contact.point_b = center - radius * contact.normal;
    contact.feature = id;
    if (feature == 0 && side < 0.0 && behind_count < kHeld) {
      behind[behind_count] = contact;
      behind_triangle[behind_count++] = t;
    } else {
      emit(contact);
    }
  });
  for (int i = 0; i < behind_count; ++i) {
    bool shallower_exit = false;
    for (int j = 0; j < behind_count && !shallower_exit; ++j)
      shallower_exit = behind[j].gap > behind[i].gap &&
                       detail::mutuallyConvex(mesh, behind_triangle[i], behind_triangle[j]);
    if (!shallower_exit) emit(behind[i]);
  }
}

template <class Emit>
void segmentSegment(const Vector3& start_a, const Vector3& end_a, double rounding_a,
                    const Vector3& start_b, const Vector3& end_b, double rounding_b, double margin,
                    Emit&& emit) {
  const Vector3 da = end_a - start_a, db = end_b - start_b;
  const Vector3 centre_a = start_a + 0.5 * da, centre_b = start_b + 0.5 * db;
  const double rounding = rounding_a + rounding_b;
  // the contact from x on a to y on b; coincident points take the axes' common normal
  auto add = [&](const Vector3& x, const Vector3& y, int feature) {
    Vector3 d = y - x;
    double distance = d.norm();
    if (!(distance > 1e-12 * std::max(rounding, 1e-300))) {
      d = da.cross(db);
      if (!(d.norm() > 0.0))
        d = da.cross(Vector3::UnitX()).norm() > 0.0 ? da.cross(Vector3::UnitX())
                                                    : da.cross(Vector3::UnitY());
      if (d.dot(centre_b - centre_a) < 0.0) d = -d;
      distance = 0.0;
    }
    ContactPoint c;
    c.normal = d.normalized();
    c.gap = distance - rounding;
    if (!(c.gap < margin)) return;
    c.point_a = x + rounding_a * c.normal;
    c.point_b = y - rounding_b * c.normal;
    c.feature = feature;
    emit(c);
  };
  // parameter on [start, start + d] of the point closest to x, and whether it is inside
  auto onto = [](const Vector3& start, const Vector3& d, const Vector3& x, bool& inside) {
    const double length2 = d.squaredNorm();
    const double s = length2 > 0.0 ? (x - start).dot(d) / length2 : 0.0;
    inside = s > 0.0 && s < 1.0;
    return std::clamp(s, 0.0, 1.0);
  };
  const Vector3 ends_a[2] = {start_a, end_a}, ends_b[2] = {start_b, end_b};
  for (int k = 0; k < 2; ++k) {  // a's ends against b: every end against an end, once
    bool inside = false;
    const double s = onto(start_b, db, ends_a[k], inside);
    add(ends_a[k], start_b + s * db, k);
  }
  for (int k = 0; k < 2; ++k) {  // b's ends against a's inside
    bool inside = false;
    const double s = onto(start_a, da, ends_b[k], inside);
    if (inside) add(start_a + s * da, ends_b[k], 2 + k);
  }
  // the closest points of the two lines, inside both segments (crossing axes; parallel ones:
  // the ends hold them)
  double s = 0.0, t = 0.0;
  if (detail::closestOnLines(start_a, da, start_b, db, s, t) && s > 0.0 && s < 1.0 && t > 0.0 &&
      t < 1.0)
    add(start_a + s * da, start_b + t * db, 4);
}

template <class Emit>
void halfSpaceShape(const Vector3& origin, const Vector3& outward, const Shape& shape,
                    const Pose& pose, double margin, Emit&& emit) {
  switch (shape.type) {
    case ShapeType::Sphere:
    case ShapeType::Disk:
      detail::emitIfClose(origin, outward, pose.translation, shape.radius, margin, 0, emit);
      return;
    case ShapeType::Capsule:
    case ShapeType::Segment: {
      Vector3 ends[2];
      if (shape.type == ShapeType::Capsule) {
        ends[0] = pose.apply(Vector3(0, 0, -0.5 * shape.length));
        ends[1] = pose.apply(Vector3(0, 0, 0.5 * shape.length));
      } else {
        ends[0] = pose.apply(shape.segment_start);
        ends[1] = pose.apply(shape.segment_end);
      }
      for (int k = 0; k < 2; ++k)
        detail::emitIfClose(origin, outward, ends[k], shape.radius, margin, k, emit);
      return;
    }
    case ShapeType::Cylinder: {
      // the deepest point of each cap rim: a cylinder lying or standing on the plane touches
      // along a line or a circle, represented by these two points
      const Vector3 axis = pose.rotation.col(2);
      Vector3 radial = -outward + axis * axis.dot(outward);
      const double norm = radial.norm();
      radial = norm > 1e-12 ? Vector3(radial / norm) : Vector3(pose.rotation.col(0));
      for (int k = 0; k < 2; ++k) {
        const Vector3 rim =
            pose.translation + (k == 0 ? -0.5 : 0.5) * shape.length * axis + shape.radius * radial;
        detail::emitIfClose(origin, outward, rim, 0.0, margin, k, emit);
      }
      return;
    }
    case ShapeType::Box:
      for (int k = 0; k < 8; ++k) {
        const Vector3 corner((k & 1) ? shape.half_extents.x() : -shape.half_extents.x(),
                             (k & 2) ? shape.half_extents.y() : -shape.half_extents.y(),
                             (k & 4) ? shape.half_extents.z() : -shape.half_extents.z());
        detail::emitIfClose(origin, outward, pose.apply(corner), 0.0, margin, k, emit);
      }
      return;
    case ShapeType::Polygon:
    case ShapeType::ConvexMesh:
    case ShapeType::TriangleMesh:
      for (std::size_t k = 0; k < shape.vertices.size(); ++k)
        detail::emitIfClose(origin, outward, pose.apply(shape.vertices[k]), 0.0, margin,
                            static_cast<int>(k), emit);
      return;
    case ShapeType::HalfSpace:
    case ShapeType::HalfPlane:
      return;  // two half-spaces: no contact point
  }
}

}  // namespace sweep
