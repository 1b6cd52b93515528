#pragma once
// Spatial algebra in Featherstone's convention ("Rigid Body Dynamics Algorithms", 2008, ch. 2),
// with compact types instead of 6x6 matrices so the tree passes stay a few hundred flops.
//
// A motion vector m = (w, v) stacks the angular velocity w and the velocity v of the point at
// the frame origin; a force vector f = (n, f) stacks the moment about the frame origin and the
// force. Both are expressed in the coordinates of the frame they refer to.
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace sweep {

using Vector2 = Eigen::Vector2d;
using Matrix2 = Eigen::Matrix2d;
using Vector3 = Eigen::Vector3d;
using Matrix3 = Eigen::Matrix3d;
using Vector6 = Eigen::Matrix<double, 6, 1>;
using Matrix6 = Eigen::Matrix<double, 6, 6>;
using Quaternion = Eigen::Quaterniond;

inline Matrix3 skew(const Vector3& a) {
  Matrix3 s;
  s << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  return s;
}

// Pose of frame B in frame A: x_A = rotation * x_B + translation.
struct Pose {
  Matrix3 rotation = Matrix3::Identity();
  Vector3 translation = Vector3::Zero();

  static Pose identity() { return Pose{}; }

  Pose operator*(const Pose& b_in_c) const {
    return Pose{rotation * b_in_c.rotation, rotation * b_in_c.translation + translation};
  }
  Pose inverse() const { return Pose{rotation.transpose(), -(rotation.transpose() * translation)}; }
  Vector3 apply(const Vector3& x_b) const { return rotation * x_b + translation; }

  // motion of a rigid body given at A's origin in A's coordinates -> at B's origin in B's
  Vector6 motionToChild(const Vector6& m_a) const {
    Vector6 out;
    const Vector3 w = m_a.head<3>();
    out.head<3>() = rotation.transpose() * w;
    out.tail<3>() = rotation.transpose() * (m_a.tail<3>() + w.cross(translation));
    return out;
  }
  // motion at B's origin in B's coordinates -> at A's origin in A's coordinates
  Vector6 motionToParent(const Vector6& m_b) const {
    Vector6 out;
    const Vector3 w = rotation * m_b.head<3>();
    out.head<3>() = w;
    out.tail<3>() = rotation * m_b.tail<3>() - w.cross(translation);
    return out;
  }
  // force about B's origin in B's coordinates -> about A's origin in A's coordinates
  Vector6 forceToParent(const Vector6& f_b) const {
    Vector6 out;
    const Vector3 f = rotation * f_b.tail<3>();
    out.tail<3>() = f;
    out.head<3>() = rotation * f_b.head<3>() + translation.cross(f);
    return out;
  }
};

// m1 x m2 (Featherstone's crm)
inline Vector6 crossMotion(const Vector6& m1, const Vector6& m2) {
  Vector6 out;
  const Vector3 w = m1.head<3>();
  out.head<3>() = w.cross(m2.head<3>());
  out.tail<3>() = w.cross(m2.tail<3>()) + m1.tail<3>().cross(m2.head<3>());
  return out;
}

// m x* f (Featherstone's crf)
inline Vector6 crossForce(const Vector6& m, const Vector6& f) {
  Vector6 out;
  const Vector3 w = m.head<3>();
  out.head<3>() = w.cross(f.head<3>()) + m.tail<3>().cross(f.tail<3>());
  out.tail<3>() = w.cross(f.tail<3>());
  return out;
}

// Rigid-body inertia in compact form: mass, centre of mass in the body frame, rotational
// inertia about the centre of mass in body axes.
struct Inertia {
  double mass = 0.0;
  Vector3 com = Vector3::Zero();
  Matrix3 inertia_com = Matrix3::Zero();

  static Inertia zero() { return Inertia{}; }

  // momentum (force vector) of a body moving with motion m
  Vector6 apply(const Vector6& m) const {
    Vector6 h;
    const Vector3 w = m.head<3>();
    const Vector3 linear = mass * (m.tail<3>() + w.cross(com));
    h.tail<3>() = linear;
    h.head<3>() = inertia_com * w + com.cross(linear);
    return h;
  }

  // the same inertia expressed in the parent frame A, given the pose of the body in A
  Inertia expressedIn(const Pose& body_in_a) const {
    return Inertia{mass, body_in_a.apply(com),
                   body_in_a.rotation * inertia_com * body_in_a.rotation.transpose()};
  }

  // the inertia of two bodies rigidly joined, both expressed in the same frame
  Inertia& operator+=(const Inertia& other) {
    const double total = mass + other.mass;
    if (other.mass == 0.0) {
      inertia_com += other.inertia_com;
      return *this;
    }
    if (mass == 0.0) {
      const Matrix3 own = inertia_com;
      *this = other;
      inertia_com += own;
      return *this;
    }
    const Vector3 c = (mass * com + other.mass * other.com) / total;
    const Vector3 d1 = com - c;
    const Vector3 d2 = other.com - c;
    // parallel-axis theorem: I_c = sum_i I_i + m_i (|d_i|^2 1 - d_i d_i^T)
    inertia_com += other.inertia_com +
                   mass * (d1.squaredNorm() * Matrix3::Identity() - d1 * d1.transpose()) +
                   other.mass * (d2.squaredNorm() * Matrix3::Identity() - d2 * d2.transpose());
    mass = total;
    com = c;
    return *this;
  }

  Matrix6 matrix() const {
    Matrix6 m;
    const Matrix3 c = skew(com);
    m.topLeftCorner<3, 3>() = inertia_com + mass * c * c.transpose();
    m.topRightCorner<3, 3>() = mass * c;
    m.bottomLeftCorner<3, 3>() = mass * c.transpose();
    m.bottomRightCorner<3, 3>() = mass * Matrix3::Identity();
    return m;
  }
};

}  // namespace sweep
