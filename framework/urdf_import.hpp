#pragma once
// URDF import (urdfdom). Each URDF link becomes a body whose frame is the link frame; each
// joint becomes the joint of its child link. Orderings and the floating-base convention are in
// docs/conventions.md.
#include <string>
#include <vector>

#include "framework/enum_names.hpp"
#include "framework/model.hpp"

namespace sweep {

enum class MissingMeshes { Refuse, Skip, InertiaBox };

template <>
struct EnumNames<MissingMeshes> {
  static constexpr EnumName<MissingMeshes> table[] = {{MissingMeshes::Refuse, "refuse"},
                                                      {MissingMeshes::Skip, "skip"},
                                                      {MissingMeshes::InertiaBox, "inertia_box"}};
};

// What a link's collision mesh is in contact: the closed surface of its convex hull (the
// default, as MuJoCo, PyBullet and Drake's point contact take meshes: CAD exports are rarely
// manifold), or its own triangles as a non-convex surface, which must then be manifold.
enum class CollisionMeshes { ConvexHull, Triangles };
template <>
struct EnumNames<CollisionMeshes> {
  static constexpr EnumName<CollisionMeshes> table[] = {
      {CollisionMeshes::ConvexHull, "convex_hull"}, {CollisionMeshes::Triangles, "triangles"}};
};

struct UrdfOptions {
  // attach the root link to the world with a floating joint (else a fixed one); ignored when
  // the root link is named "world", whose child joints then attach to the world directly
  bool floating_base = false;
  Pose base_placement;      // root joint frame in world
  std::string name_prefix;  // prepended to body and joint names (several instances per scene)
  // Folders searched for the package of a `package://PKG/...` mesh, first to last, before
  // $ROS_PACKAGE_PATH and the URDF file's own ancestors: a folder PKG holding package.xml, at
  // most four levels below one of them (as ROS's crawl finds packages).
  std::vector<std::string> package_paths;
  // A collision mesh whose file is missing: refused (naming it), left out, or replaced by the
  // box with the link's mass and inertia at its inertial frame. What was replaced is kept in
  // CollisionGeometry::missing_mesh for the run's description.
  MissingMeshes missing_meshes = MissingMeshes::Refuse;
  CollisionMeshes collision_meshes = CollisionMeshes::ConvexHull;
};

// Adds the URDF's tree to a builder; returns the builder index of the root body.
int addUrdf(ModelBuilder& builder, const std::string& path, const UrdfOptions& options = {});
// The same from XML text; `source` names it in error messages.
int addUrdfString(ModelBuilder& builder, const std::string& xml, const std::string& source,
                  const UrdfOptions& options = {});

// A model holding just this URDF.
Model loadUrdf(const std::string& path, const UrdfOptions& options = {});

}  // namespace sweep
