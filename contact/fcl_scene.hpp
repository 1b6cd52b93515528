#pragma once
// The general detection path on FCL. FCL types stay inside fcl_scene.cpp; the rest of Sweep
// sees geometry indices, poses and ContactPoints.
#include <memory>
#include <utility>
#include <vector>

#include "contact/contact_model.hpp"
#include "contact/narrowphase_analytic.hpp"

namespace sweep {

class FclScene {
 public:
  explicit FclScene(const ContactModel& cmodel);
  ~FclScene();
  FclScene(const FclScene&) = delete;
  FclScene& operator=(const FclScene&) = delete;

  // Moves every bounded shape to its world pose and refits the dynamic AABB tree, with boxes
  // grown by margin / 2 on each side so that overlapping boxes contain every pair closer
  // than the margin.
  void update(const std::vector<Pose>& geometry_poses, double margin);

  // Pairs of bounded geometries (a < b) whose grown boxes overlap; appended.
  void findPairs(std::vector<std::pair<int, int>>& pairs);

  // FCL narrowphase for two bounded geometries: distance and witness points when separated
  // (GJK, or FCL's closed forms for sphere pairs), penetration by collision otherwise (EPA,
  // several points for boxes and meshes). Calls emit(ContactPoint) for gaps below margin.
  void narrowphase(int a, int b, double margin, std::vector<ContactPoint>& out) const;

  // Whether FCL holds a geometry for this index (half-spaces are handled outside FCL: its
  // distance query dereferences a missing support function for them).
  bool has(int geometry) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sweep
