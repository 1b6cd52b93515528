#pragma once
// The convex hull of a triangle mesh's vertices (Qhull: Barber, Dobkin & Huhdanpaa 1996, "The
// Quickhull algorithm for convex hulls", ACM TOMS 22), as a closed, outward, triangulated
// TriangleMesh (for Shape::convexMesh or Shape::triangleMesh). Robot links' collision meshes go
// through it by default (urdf[].collision_meshes), as MuJoCo, PyBullet and Drake's point contact
// take them: CAD exports are often not manifold, and a link's hull holds what rests on it.
#include <memory>
#include <string>

#include "contact/shape.hpp"

namespace sweep {

// InputError starting with `where` when the vertices span no volume (fewer than four, all on
// a plane or a line) or are not finite.
std::shared_ptr<TriangleMesh> convexHull(const TriangleMesh& mesh, const std::string& where);

}  // namespace sweep
