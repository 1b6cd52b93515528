#pragma once
// Template part of narrowphase_analytic.hpp.
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
}  // namespace detail

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
