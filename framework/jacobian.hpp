#pragma once
#include "framework/data.hpp"

namespace sweep {

// Jacobian of a point attached to `body` with respect to v (after forwardKinematics):
// rows 0-2 map v to the body's angular velocity, rows 3-5 to the velocity of the point, both in
// world axes. Only the columns of the body and its ancestors are written; J must be 6 x nv and
// its other columns are left untouched (callers zero it once).
void pointJacobian(const Model& model, const Data& data, int body, const Vector3& point_world,
                   Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>> J);

// Jacobian of the frame `frame_in_body` of `body`: its angular velocity and the velocity of
// its origin, in world axes.
void frameJacobian(const Model& model, const Data& data, int body, const Pose& frame_in_body,
                   Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>> J);

// Calls visit(v_index, angular_world, linear_world_at_point) for every dof moving the point.
template <class Visit>
void forEachPointJacobianColumn(const Model& model, const Data& data, int body,
                                const Vector3& point_world, Visit&& visit) {
  for (int j = body; j >= 0; j = model.bodies[j].parent) {
    const Pose& pose = data.world_pose[j];
    const MotionSubspace& S = data.motion_subspace[j];
    const Vector3 lever = point_world - pose.translation;
    if (model.bodies[j].joint.type == JointType::Floating) {
      // The linear velocity is in the joint's parent frame, so its columns are that frame's
      // axes: taken as they are, not as R (R^T e_k), whose round-off differs from body to
      // body. A free particle's columns are then exactly the world axes, and two spheres'
      // rows share them to the bit (ContactProblem::PackedBodies3d).
      const Body& b = model.bodies[j];
      const Matrix3 frame =
          b.parent < 0 ? b.joint_placement.rotation
                       : Matrix3(data.world_pose[b.parent].rotation * b.joint_placement.rotation);
      for (int k = 0; k < 3; ++k) visit(b.v_index + k, Vector3::Zero().eval(), frame.col(k).eval());
      // the angular velocity is in body axes: its columns are the body's axes (S is not read,
      // a 300-byte record per body)
      for (int k = 0; k < 3; ++k) {
        const Vector3 w = pose.rotation.col(k);
        visit(b.v_index + 3 + k, w, w.cross(lever).eval());
      }
      continue;
    }
    for (int k = 0; k < S.cols(); ++k) {
      const Vector3 w = pose.rotation * S.col(k).head<3>();
      const Vector3 lin = pose.rotation * S.col(k).tail<3>() + w.cross(lever);
      visit(model.bodies[j].v_index + k, w, lin);
    }
  }
}

}  // namespace sweep
