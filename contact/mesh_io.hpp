#pragma once
// Reads triangle meshes (STL, OBJ, COLLADA and every format assimp knows) into a TriangleMesh.
#include <memory>
#include <string>

#include "contact/shape.hpp"

namespace sweep {

// Vertices are merged and scaled per axis. Throws InputError naming the file when it is
// missing, unreadable or holds no triangles.
std::shared_ptr<TriangleMesh> loadTriangleMesh(const std::string& path,
                                               const Vector3& scale = Vector3::Ones());

}  // namespace sweep
