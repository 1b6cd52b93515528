#include "framework/configuration.hpp"

#include "framework/parallel.hpp"

#include <stdexcept>
#include <string>

namespace sweep {

namespace {

Quaternion quaternionAt(const VectorX& q, int index) {
  return Quaternion(q[index + 6], q[index + 3], q[index + 4], q[index + 5]);
}

void storeQuaternion(const Quaternion& quat, VectorX& q, int index) {
  q[index + 3] = quat.x();
  q[index + 4] = quat.y();
  q[index + 5] = quat.z();
  q[index + 6] = quat.w();
}

Quaternion exponential(const Vector3& rotation_vector) {
  const double angle = rotation_vector.norm();
  if (angle < 1e-300) return Quaternion::Identity();
  return Quaternion(Eigen::AngleAxisd(angle, rotation_vector / angle));
}

}  // namespace

void integrate(const Model& model, const VectorX& q, const VectorX& dv, VectorX& q_out, int threads,
               const std::vector<int>* components) {
  if (&q_out != &q) q_out = q;
  forEachBodyComponent(model, components, threads, [&](int c) {
    const Component& comp = model.components[c];
    for (int i = comp.first_body; i < comp.end_body; ++i) {
      const Body& b = model.bodies[i];
      const int iq = b.q_index, iv = b.v_index;
      if (b.joint.type != JointType::Floating) {
        q_out.segment(iq, b.joint.nq()) += dv.segment(iv, b.joint.nv());
        continue;
      }
      q_out.segment<3>(iq) += dv.segment<3>(iv);
      const Quaternion rotated =
          (quaternionAt(q_out, iq) * exponential(dv.segment<3>(iv + 3))).normalized();
      storeQuaternion(rotated, q_out, iq);
    }
  });
  for (const Component& c : model.components) {
    if (c.system < 0) continue;
    const EquationSystem& system = model.systems[c.system];
    if (!system.integrate) {
      q_out.segment(c.q_index, c.nq) += dv.segment(c.v_index, c.nv);
      continue;
    }
    const VectorX moved = system.integrate(q.segment(c.q_index, c.nq), dv.segment(c.v_index, c.nv));
    if (moved.size() != c.nq)
      throw std::runtime_error("system '" + system.name + "': integrate returned " +
                               std::to_string(moved.size()) +
                               " entries, not nq = " + std::to_string(c.nq));
    q_out.segment(c.q_index, c.nq) = moved;
  }
}

VectorX integrate(const Model& model, const VectorX& q, const VectorX& dv) {
  VectorX out;
  integrate(model, q, dv, out);
  return out;
}

VectorX difference(const Model& model, const VectorX& q0, const VectorX& q1) {
  VectorX dv(model.nv);
  for (const Body& b : model.bodies) {
    const int iq = b.q_index, iv = b.v_index;
    if (b.joint.type != JointType::Floating) {
      dv.segment(iv, b.joint.nv()) = q1.segment(iq, b.joint.nq()) - q0.segment(iq, b.joint.nq());
      continue;
    }
    dv.segment<3>(iv) = q1.segment<3>(iq) - q0.segment<3>(iq);
    const Eigen::AngleAxisd relative(
        (quaternionAt(q0, iq).normalized().conjugate() * quaternionAt(q1, iq).normalized())
            .normalized());
    // the shortest rotation: angle in [0, pi]
    double angle = relative.angle();
    Vector3 axis = relative.axis();
    if (angle > M_PI) {
      angle = 2.0 * M_PI - angle;
      axis = -axis;
    }
    dv.segment<3>(iv + 3) = angle * axis;
  }
  for (const Component& c : model.components) {
    if (c.system < 0) continue;
    if (model.systems[c.system].integrate)
      throw std::logic_error("difference: system '" + model.systems[c.system].name +
                             "' has its own integrate, and no inverse of it");
    dv.segment(c.v_index, c.nv) = q1.segment(c.q_index, c.nq) - q0.segment(c.q_index, c.nq);
  }
  return dv;
}

void configurationRate(const Model& model, const VectorX& q, const VectorX& v, VectorX& qdot) {
  qdot.resize(model.nq);
  for (const Body& b : model.bodies) {
    const int iq = b.q_index, iv = b.v_index;
    if (b.joint.type != JointType::Floating) {
      qdot.segment(iq, b.joint.nq()) = v.segment(iv, b.joint.nv());
      continue;
    }
    qdot.segment<3>(iq) = v.segment<3>(iv);
    const Vector3 w = v.segment<3>(iv + 3);
    const Quaternion rate = quaternionAt(q, iq) * Quaternion(0.0, w.x(), w.y(), w.z());
    qdot.segment<4>(iq + 3) = 0.5 * rate.coeffs();  // coeffs() is (x, y, z, w)
  }
  for (const Component& c : model.components) {
    if (c.system < 0) continue;
    if (model.systems[c.system].integrate)
      throw std::logic_error("configurationRate: system '" + model.systems[c.system].name +
                             "' has its own integrate");
    qdot.segment(c.q_index, c.nq) = v.segment(c.v_index, c.nv);
  }
}

namespace {
VectorX rotateFloatingLinear(const Model& model, const VectorX& q, const VectorX& v, bool to_body) {
  VectorX out = v;
  for (const Body& b : model.bodies) {
    if (b.joint.type != JointType::Floating) continue;
    const Eigen::Quaterniond rotation(q[b.q_index + 6], q[b.q_index + 3], q[b.q_index + 4],
                                      q[b.q_index + 5]);
    const Matrix3 R = rotation.normalized().toRotationMatrix();
    const Vector3 linear = v.segment<3>(b.v_index);
    out.segment<3>(b.v_index) = to_body ? Vector3(R.transpose() * linear) : Vector3(R * linear);
  }
  return out;
}
}  // namespace

VectorX velocityToBodyFrame(const Model& model, const VectorX& q, const VectorX& v) {
  return rotateFloatingLinear(model, q, v, true);
}

VectorX velocityFromBodyFrame(const Model& model, const VectorX& q, const VectorX& v_body) {
  return rotateFloatingLinear(model, q, v_body, false);
}

void normalizeConfiguration(const Model& model, VectorX& q, int threads,
                            const std::vector<int>* components) {
  forEachBodyComponent(model, components, threads, [&](int c) {
    const Component& comp = model.components[c];
    for (int i = comp.first_body; i < comp.end_body; ++i) {
      const Body& b = model.bodies[i];
      if (b.joint.type == JointType::Floating)
        storeQuaternion(quaternionAt(q, b.q_index).normalized(), q, b.q_index);
    }
  });
}

}  // namespace sweep
