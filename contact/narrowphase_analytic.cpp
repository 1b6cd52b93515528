#include "contact/narrowphase_analytic.hpp"

#include <algorithm>

namespace sweep {

bool hasAnalyticNarrowphase(ShapeType a, ShapeType b) {
  if (b < a) std::swap(a, b);
  using T = ShapeType;
  switch (b) {
    case T::Sphere:
      return a == T::Sphere;
    case T::Box:  // box-box: its surface mesh (narrowphase_mesh.hpp)
      return a == T::Sphere || a == T::Box;
    case T::Capsule:  // box-capsule: the box's surface mesh
      return a == T::Sphere || a == T::Box || a == T::Capsule;
    case T::ConvexMesh:  // as its surface, a closed triangle mesh
    case T::TriangleMesh:
      return a == T::Sphere || a == T::Box || a == T::Capsule;  // narrowphase_mesh.hpp
    case T::HalfSpace:  // a mesh: its vertices (halfSpaceShape)
      return a == T::Sphere || a == T::Box || a == T::Capsule || a == T::Cylinder ||
             a == T::ConvexMesh || a == T::TriangleMesh;
    case T::Disk:
      return a == T::Disk;
    case T::Segment:
      return a == T::Disk;
    case T::HalfPlane:
      return a == T::Disk || a == T::Segment || a == T::Polygon;
    default:
      return false;
  }
}

ContactPoint segmentBall(const Vector3& start, const Vector3& end, double rounding,
                         const Vector3& center, double radius) {
  const Vector3 axis = end - start;
  const double s = std::clamp((center - start).dot(axis) / axis.squaredNorm(), 0.0, 1.0);
  return ballBall(start + s * axis, rounding, center, radius);
}

ContactPoint halfSpaceBall(const Vector3& origin, const Vector3& outward, const Vector3& center,
                           double radius) {
  ContactPoint c;
  c.normal = outward;
  c.gap = (center - origin).dot(outward) - radius;
  c.point_b = center - radius * outward;
  c.point_a = c.point_b - c.gap * outward;
  return c;
}

ContactPoint boxBall(const Pose& box_pose, const Vector3& half_extents, const Vector3& center,
                     double radius) {
  const Vector3 local = box_pose.rotation.transpose() * (center - box_pose.translation);
  const Vector3 clamped = local.cwiseMax(-half_extents).cwiseMin(half_extents);
  ContactPoint c;
  if (clamped != local) {
    // centre outside: the nearest box point is the clamped one
    const Vector3 d = local - clamped;
    const double distance = d.norm();
    c.normal = box_pose.rotation * (d / distance);
    c.gap = distance - radius;
    c.point_a = box_pose.apply(clamped);
  } else {
    // centre inside: leave through the face with the least depth
    int axis = 0;
    double least = half_extents[0] - std::abs(local[0]);
    for (int k = 1; k < 3; ++k) {
      const double depth = half_extents[k] - std::abs(local[k]);
      if (depth < least) {
        least = depth;
        axis = k;
      }
    }
    const double side = local[axis] < 0.0 ? -1.0 : 1.0;
    Vector3 face_point = local;
    face_point[axis] = side * half_extents[axis];
    c.normal = box_pose.rotation.col(axis) * side;
    c.gap = -least - radius;
    c.point_a = box_pose.apply(face_point);
  }
  c.point_b = center - radius * c.normal;
  return c;
}

}  // namespace sweep
