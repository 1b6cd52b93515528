#pragma once
// Joint kinds of the Lagrangian layer and their kinematics (joint transform, motion subspace S,
// and the apparent derivative c_J = (dS/dt) v of Featherstone's Table 4.1).
//
// Coordinate conventions (also in docs/conventions.md):
//   revolute/continuous  q = angle about `axis`,          v = its rate
//   prismatic            q = displacement along `axis`,   v = its rate
//   fixed                no coordinates
//   planar               q = (x, y, theta), v = (xdot, ydot, thetadot); x, y along the in-plane
//                        axes e1, e2 of the joint frame, theta about its normal n = e1 x e2;
//                        velocities are coordinate rates, so q_{k+1} = q_k + h v exactly
//   floating             q = (px, py, pz, qx, qy, qz, qw) (unit quaternion, Eigen order),
//                        v = (linear velocity of the body origin in the parent frame,
//                             angular velocity in body axes)
// The floating convention makes M constant for a body whose origin is its centre of mass, so
// free particles never rebuild or refactor their mass block.
#include <string>

#include "framework/spatial.hpp"

namespace sweep {

enum class JointType { Revolute, Continuous, Prismatic, Fixed, Planar, Floating };

std::string toString(JointType type);

struct Joint {
  JointType type = JointType::Fixed;
  Vector3 axis = Vector3::UnitZ();  // rotation/translation axis; plane normal for Planar
  // in-plane axes of a planar joint, fixed once here rather than per kinematic pass
  Vector3 plane_x = Vector3::UnitX();
  Vector3 plane_y = Vector3::UnitY();

  static Joint revolute(const Vector3& axis) { return {JointType::Revolute, axis.normalized()}; }
  static Joint continuous(const Vector3& axis) {
    return {JointType::Continuous, axis.normalized()};
  }
  static Joint prismatic(const Vector3& axis) { return {JointType::Prismatic, axis.normalized()}; }
  static Joint fixed() { return {JointType::Fixed, Vector3::UnitZ()}; }
  static Joint planar(const Vector3& normal = Vector3::UnitZ());
  static Joint floating() { return {JointType::Floating, Vector3::UnitZ()}; }

  int nq() const;
  int nv() const;
  bool hasLimits() const { return type == JointType::Revolute || type == JointType::Prismatic; }
};

// In-plane unit axes (e1, e2) of a planar joint with normal n, chosen so that e1 x e2 = n and
// (e1, e2) = (x, y) when n = z.
void planarAxes(const Vector3& normal, Vector3& e1, Vector3& e2);

// Motion subspace S of a joint: its first `dof` columns are used. Fixed-size storage and
// explicit loops: with at most 6 columns, Eigen's dynamic-size kernels cost more than the work.
struct MotionSubspace {
  Matrix6 columns = Matrix6::Zero();
  int dof = 0;

  int cols() const { return dof; }
  auto col(int k) const { return columns.col(k); }
  // S v for the joint velocity v (dof entries)
  Vector6 apply(const double* v) const {
    Vector6 out = Vector6::Zero();
    for (int k = 0; k < dof; ++k) out += columns.col(k) * v[k];
    return out;
  }
  // out = S^T f
  void applyTranspose(const Vector6& f, double* out) const {
    for (int k = 0; k < dof; ++k) out[k] = columns.col(k).dot(f);
  }
};

// Joint transform (child frame in joint frame) for joint coordinates q (nq entries).
Pose jointTransform(const Joint& joint, const double* q);

// Motion subspace S (6 x nv, child coordinates) and c_J = Sdot v for joint velocity v.
void jointMotion(const Joint& joint, const Pose& joint_transform, const double* v,
                 MotionSubspace& S, Vector6& c_j);

}  // namespace sweep
