#pragma once
#include "framework/data.hpp"

namespace sweep {

// Poses and motion subspaces of every body at configuration q.
void forwardKinematics(const Model& model, Data& data, const VectorX& q);
// The same, plus spatial body velocities and the joint bias accelerations c_J.
void forwardKinematics(const Model& model, Data& data, const VectorX& q, const VectorX& v);

// World position of a point given in the frame of `body` (after forwardKinematics).
inline Vector3 bodyPointInWorld(const Data& data, int body, const Vector3& point_in_body) {
  return data.world_pose[body].apply(point_in_body);
}

}  // namespace sweep
