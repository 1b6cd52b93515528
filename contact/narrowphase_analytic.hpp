#pragma once
// Closed-form narrowphase for the pairs of particle scenes. Every function returns the gap,
// the unit normal from the first shape to the second and the witness points, in world frame,
// whether the shapes are separated, touching or overlapping.
#include "contact/shape.hpp"

namespace sweep {

struct ContactPoint {
  double gap = 0.0;
  Vector3 normal = Vector3::UnitZ();
  Vector3 point_a = Vector3::Zero();
  Vector3 point_b = Vector3::Zero();
  int feature = 0;
};

// whether the analytic narrowphase handles this pair of shape types (in either order)
bool hasAnalyticNarrowphase(ShapeType a, ShapeType b);

// Ball (sphere, or disk in its plane) against ball. Coincident centres get normal +x.
inline ContactPoint ballBall(const Vector3& center_a, double radius_a, const Vector3& center_b,
                             double radius_b) {
  ContactPoint c;
  const Vector3 d = center_b - center_a;
  const double distance = d.norm();
  c.normal = distance > 0.0 ? Vector3(d / distance) : Vector3::UnitX();
  c.gap = distance - radius_a - radius_b;
  c.point_a = center_a + radius_a * c.normal;
  c.point_b = center_b - radius_b * c.normal;
  return c;
}

// Rounded segment [start, end] against ball.
ContactPoint segmentBall(const Vector3& start, const Vector3& end, double rounding,
                         const Vector3& center, double radius);

// Rounded segment against rounded segment (capsule against capsule): each end against the
// other segment where its closest point there is inside it (an end against an end once, from
// the first), and the two segments' closest points where they lie inside both. Capsules side
// by side get a point at each end of their overlap, crossing ones their closest points.
// Features: 0, 1 the first's ends, 2, 3 the second's, 4 the inner points. Points with a gap
// below `margin`; calls emit(ContactPoint).
template <class Emit>
void segmentSegment(const Vector3& start_a, const Vector3& end_a, double rounding_a,
                    const Vector3& start_b, const Vector3& end_b, double rounding_b, double margin,
                    Emit&& emit);

// Half-space {x : (x - origin) . outward <= 0} against ball.
ContactPoint halfSpaceBall(const Vector3& origin, const Vector3& outward, const Vector3& center,
                           double radius);

// Box (pose, half extents) against ball. A centre inside the box is pushed out through the
// nearest face.
ContactPoint boxBall(const Pose& box_pose, const Vector3& half_extents, const Vector3& center,
                     double radius);

// Triangle mesh (non-convex, a surface with a front: counter-clockwise) at `pose` against a
// ball. A triangle's face gives a contact along its normal while the centre is in front of
// it, or behind it by less than the radius (a ball crossing the surface is pushed back to the
// front). An edge or vertex gives one only where it is the closest feature of every triangle
// that holds it (a ridge or a rim): the edges inside a flat or concave patch, which FCL
// reports with tilted normals, give none. Points with a gap below `margin`, each once; feature:
// the triangle for a face, triangles + 3 x triangle + edge for an edge, 4 x triangles + vertex
// for a vertex. Calls emit(ContactPoint).
template <class Emit>
void meshBall(const Pose& pose, const TriangleMesh& mesh, const Vector3& center, double radius,
              double margin, Emit&& emit);

// meshBall for a point of a convex shape rounded by `radius` (0 for a box's corner): a face
// pushes it back to the front while it is less than `depth` behind (a ball's radius, a box's
// least half extent).
template <class Emit>
void meshPoint(const Pose& pose, const TriangleMesh& mesh, const Vector3& center, double radius,
               double depth, double margin, Emit&& emit);

// Half-space against a convex shape or triangle mesh at `pose`: one contact point per vertex
// (box, polygon, mesh), per end (segment, capsule: rounded ends) or per cap rim (cylinder)
// whose gap is below `margin`, feature = that vertex or end. Calls emit(ContactPoint).
template <class Emit>
void halfSpaceShape(const Vector3& origin, const Vector3& outward, const Shape& shape,
                    const Pose& pose, double margin, Emit&& emit);

}  // namespace sweep

#include "contact/narrowphase_analytic_inl.hpp"
