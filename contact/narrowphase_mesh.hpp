#pragma once
// Boxes and capsules against a non-convex triangle mesh, in closed form. FCL 0.7 answers these
// pairs with one point per triangle and depths that let a resting box sink through a floor.
//
// A contact between a convex polyhedron and a polyhedral surface is made of three kinds of
// points, each kept where its gap is below the margin, with the normal from the mesh to the
// shape:
// - the shape's corners (a capsule's rounded ends) against the mesh's faces, ridges and rims,
//   as meshBall takes a ball; a corner is pushed back while it is less than the box's least
//   half extent (a capsule's radius) behind a face;
// - the mesh's convex vertices (peaks, and points of ridges and rims) against the box's faces
//   or the capsule's side, where the normal lies in the vertex's cone (the mesh is behind the
//   plane through the vertex);
// - the mesh's convex edges (ridges, rims) against the box's edges or the capsule's axis, where
//   the two lines' closest points lie inside both segments and the normal lies in both edges'
//   cones;
// - for a capsule, where its axis crosses a convex edge of a face rising toward the edge (the
//   axis tilts down toward the face, so the edge's cone refuses the edge-axis normal), that
//   crossing against the face: a capsule across a rim narrower than itself, rocking.
// On a flat or concave patch (a floor, a bowl) the corners alone hold the shape; the other
// kinds carry it across ridges and peaks. The mesh's tree of boxes gives the triangles near
// the shape.
//
// Feature ids, with F = 4 x triangles + vertices (meshBall's ids): corner c (a capsule's end)
// against mesh feature f is c F + f; then one per mesh vertex; then one per pair of a mesh
// edge (3 x triangle + edge) and a box edge (12 per mesh edge; 1 for the capsule's axis); then,
// for a capsule, one per face's edge crossed (3 x triangle + edge).
#include <vector>

#include "contact/narrowphase_analytic.hpp"

namespace sweep {

void meshBox(const Pose& mesh_pose, const TriangleMesh& mesh, const Pose& box_pose,
             const Vector3& half_extents, double margin, std::vector<ContactPoint>& out);

// The capsule's axis runs from `start` to `end` (world).
void meshCapsule(const Pose& mesh_pose, const TriangleMesh& mesh, const Vector3& start,
                 const Vector3& end, double radius, double margin, std::vector<ContactPoint>& out);

}  // namespace sweep
