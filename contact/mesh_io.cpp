#include "contact/mesh_io.hpp"

#include <array>
#include <cmath>
#include <map>
#include <vector>

#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <assimp/Importer.hpp>
#include <filesystem>
#include <functional>

#include "framework/error.hpp"

namespace sweep {

std::shared_ptr<TriangleMesh> loadTriangleMesh(const std::string& path, const Vector3& scale) {
  std::error_code error;
  if (std::filesystem::is_directory(path, error))
    throw InputError(path + ": is a folder, not a mesh file");
  if (!std::filesystem::is_regular_file(path, error))
    throw InputError(path + ": mesh file not found");
  // a zero scale flattens the mesh to a point; a negative one turns it inside out
  for (int k = 0; k < 3; ++k)
    if (!(scale[k] > 0.0) || !std::isfinite(scale[k]))
      throw InputError(path + ": mesh scale must be > 0 and finite in each axis, got [" +
                       formatValue(scale.x()) + " " + formatValue(scale.y()) + " " +
                       formatValue(scale.z()) + "]");
  Assimp::Importer importer;
  // A COLLADA file is read as ROS reads it (RViz, Gazebo, MoveIt): its <unit> scales it, its
  // <up_axis> does not turn it. assimp's default turns Z_UP files, the CAD exports robot
  // packages ship, a quarter turn about x into its own Y-up frame.
  importer.SetPropertyBool(AI_CONFIG_IMPORT_COLLADA_IGNORE_UP_DIRECTION, true);
  // identical vertices are merged so that edge sharing (manifold checks) can be seen
  const aiScene* scene = importer.ReadFile(
      path, aiProcess_Triangulate | aiProcess_JoinIdenticalVertices | aiProcess_SortByPType);
  if (scene == nullptr) throw InputError(path + ": cannot read mesh: " + importer.GetErrorString());

  auto mesh = std::make_shared<TriangleMesh>();
  // node transforms place sub-meshes (COLLADA); STL has one identity node
  std::function<void(const aiNode*, const aiMatrix4x4&)> visit = [&](const aiNode* node,
                                                                     const aiMatrix4x4& parent) {
    const aiMatrix4x4 transform = parent * node->mTransformation;
    // a node scaled to 0 on an axis flattens its parts; a mirroring one turns them inside out,
    // which reversing their triangles undoes
    const double det = node->mNumMeshes > 0 ? transform.Determinant() : 1.0;
    if (!(std::abs(det) > 0.0) || !std::isfinite(det))
      throw InputError(path + ": node '" + std::string(node->mName.C_Str()) +
                       "': its transform flattens the mesh (determinant " + formatValue(det) +
                       "): a node's scale must be non-zero in each axis");
    const bool mirrored = det < 0.0;
    for (unsigned m = 0; m < node->mNumMeshes; ++m) {
      const aiMesh* part = scene->mMeshes[node->mMeshes[m]];
      const int offset = static_cast<int>(mesh->vertices.size());
      for (unsigned i = 0; i < part->mNumVertices; ++i) {
        const aiVector3D p = transform * part->mVertices[i];
        mesh->vertices.emplace_back(scale.x() * p.x, scale.y() * p.y, scale.z() * p.z);
      }
      for (unsigned f = 0; f < part->mNumFaces; ++f) {
        const aiFace& face = part->mFaces[f];
        if (face.mNumIndices != 3) continue;  // points and lines carry no surface
        const int first = offset + static_cast<int>(face.mIndices[0]);
        const int second = offset + static_cast<int>(face.mIndices[mirrored ? 2 : 1]);
        const int third = offset + static_cast<int>(face.mIndices[mirrored ? 1 : 2]);
        mesh->triangles.push_back({first, second, third});
      }
    }
    for (unsigned c = 0; c < node->mNumChildren; ++c) visit(node->mChildren[c], transform);
  };
  visit(scene->mRootNode, aiMatrix4x4());
  if (mesh->triangles.empty()) throw InputError(path + ": mesh has no triangles");
  // assimp joins only vertices equal in every attribute, and an STL facet's normal is one:
  // vertices at one position become one here, or a curved surface would have no shared edge
  std::map<std::array<double, 3>, int> index;
  std::vector<int> merged(mesh->vertices.size());
  std::vector<Vector3> vertices;
  for (std::size_t i = 0; i < mesh->vertices.size(); ++i) {
    const Vector3& p = mesh->vertices[i];
    if (!p.allFinite()) {  // no order holds a NaN: kept apart, for validateShape to name
      merged[i] = static_cast<int>(vertices.size());
      vertices.push_back(p);
      continue;
    }
    const auto [it, fresh] = index.emplace(std::array<double, 3>{p.x(), p.y(), p.z()},
                                           static_cast<int>(vertices.size()));
    if (fresh) vertices.push_back(p);
    merged[i] = it->second;
  }
  for (auto& triangle : mesh->triangles)
    for (int& v : triangle) v = merged[v];
  mesh->vertices = std::move(vertices);
  return mesh;
}

}  // namespace sweep
