#include "framework/joint.hpp"

namespace sweep {

std::string toString(JointType type) {
  switch (type) {
    case JointType::Revolute:
      return "revolute";
    case JointType::Continuous:
      return "continuous";
    case JointType::Prismatic:
      return "prismatic";
    case JointType::Fixed:
      return "fixed";
    case JointType::Planar:
      return "planar";
    case JointType::Floating:
      return "floating";
  }
  return "unknown";
}

int Joint::nq() const {
  switch (type) {
    case JointType::Revolute:
    case JointType::Continuous:
    case JointType::Prismatic:
      return 1;
    case JointType::Fixed:
      return 0;
    case JointType::Planar:
      return 3;
    case JointType::Floating:
      return 7;
  }
  return 0;
}

int Joint::nv() const {
  return type == JointType::Floating ? 6 : (nq());
}

Joint Joint::planar(const Vector3& normal) {
  Joint joint{JointType::Planar, normal.normalized()};
  planarAxes(joint.axis, joint.plane_x, joint.plane_y);
  return joint;
}

void planarAxes(const Vector3& normal, Vector3& e1, Vector3& e2) {
  // the x axis projected on the plane, or y when x is (nearly) the normal itself
  const Vector3 seed = std::abs(normal.x()) < 0.9 ? Vector3::UnitX() : Vector3::UnitY();
  e1 = (seed - normal * normal.dot(seed)).normalized();
  e2 = normal.cross(e1);
}

Pose jointTransform(const Joint& joint, const double* q) {
  Pose x;
  switch (joint.type) {
    case JointType::Revolute:
    case JointType::Continuous: {
      // Rodrigues: R = c 1 + s [a]x + (1 - c) a a^T
      const double c = std::cos(q[0]), s = std::sin(q[0]);
      const Vector3& a = joint.axis;
      x.rotation = (1.0 - c) * (a * a.transpose());
      x.rotation.diagonal().array() += c;
      x.rotation += s * skew(a);
      break;
    }
    case JointType::Prismatic:
      x.translation = joint.axis * q[0];
      break;
    case JointType::Fixed:
      break;
    case JointType::Planar: {
      const Vector3& e1 = joint.plane_x;
      const Vector3& e2 = joint.plane_y;
      x.rotation = Eigen::AngleAxisd(q[2], joint.axis).toRotationMatrix();
      x.translation = q[0] * e1 + q[1] * e2;
      break;
    }
    case JointType::Floating:
      x.translation = Vector3(q[0], q[1], q[2]);
      x.rotation = Quaternion(q[6], q[3], q[4], q[5]).normalized().toRotationMatrix();
      break;
  }
  return x;
}

void jointMotion(const Joint& joint, const Pose& xj, const double* v, MotionSubspace& S,
                 Vector6& c_j) {
  c_j.setZero();
  switch (joint.type) {
    case JointType::Revolute:
    case JointType::Continuous:
      S.dof = 1;
      S.columns.col(0) << joint.axis, Vector3::Zero();
      break;
    case JointType::Prismatic:
      S.dof = 1;
      S.columns.col(0) << Vector3::Zero(), joint.axis;
      break;
    case JointType::Fixed:
      S.dof = 0;
      break;
    case JointType::Planar: {
      const Vector3& e1 = joint.plane_x;
      const Vector3& e2 = joint.plane_y;
      const Matrix3 rt = xj.rotation.transpose();
      S.dof = 3;
      S.columns.col(0) << Vector3::Zero(), rt * e1;
      S.columns.col(1) << Vector3::Zero(), rt * e2;
      S.columns.col(2) << joint.axis, Vector3::Zero();  // R^T n = n for a rotation about n
      // translational rates are parent-frame quantities: their child-frame image rotates
      const Vector3 w = joint.axis * v[2];
      const Vector3 v_child = rt * (v[0] * e1 + v[1] * e2);
      c_j.tail<3>() = -w.cross(v_child);
      break;
    }
    case JointType::Floating: {
      const Matrix3 rt = xj.rotation.transpose();
      S.dof = 6;
      S.columns.setZero();
      S.columns.bottomLeftCorner<3, 3>() = rt;
      S.columns.topRightCorner<3, 3>().setIdentity();
      const Vector3 w(v[3], v[4], v[5]);
      const Vector3 v_child = rt * Vector3(v[0], v[1], v[2]);
      c_j.tail<3>() = -w.cross(v_child);
      break;
    }
  }
}

}  // namespace sweep
