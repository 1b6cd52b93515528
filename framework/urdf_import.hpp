#pragma once
// URDF import (urdfdom). Each URDF link becomes a body whose frame is the link frame; each
// joint becomes the joint of its child link. Orderings and the floating-base convention are in
// docs/conventions.md.
#include <string>

#include "framework/model.hpp"

namespace sweep {

struct UrdfOptions {
  // attach the root link to the world with a floating joint (else a fixed one); ignored when
  // the root link is named "world", whose child joints then attach to the world directly
  bool floating_base = false;
  Pose base_placement;      // root joint frame in world
  std::string name_prefix;  // prepended to body and joint names (several instances per scene)
};

// Adds the URDF's tree to a builder; returns the builder index of the root body.
int addUrdf(ModelBuilder& builder, const std::string& path, const UrdfOptions& options = {});
// The same from XML text; `source` names it in error messages.
int addUrdfString(ModelBuilder& builder, const std::string& xml, const std::string& source,
                  const UrdfOptions& options = {});

// A model holding just this URDF.
Model loadUrdf(const std::string& path, const UrdfOptions& options = {});

}  // namespace sweep
