#include "framework/kinematics.hpp"

#include "framework/parallel.hpp"

namespace sweep {

namespace {

// one forward pass; v == nullptr skips velocities (c_J is then evaluated at zero velocity)
void forwardPass(const Model& model, Data& data, const VectorX& q, const VectorX* v) {
  static const double kZeroVelocity[6] = {0, 0, 0, 0, 0, 0};
  if (!model.systems.empty()) {
    data.q = q;
    if (v)
      data.v = *v;
    else
      data.v.setZero(model.nv);
  }
  // tree by tree, each in body order (a parent before its children)
  forEachBodyComponent(model, data.componentSubset(), data.threads, [&](int c) {
    const Component& comp = model.components[c];
    for (int i = comp.first_body; i < comp.end_body; ++i) {
      const Body& body = model.bodies[i];
      const Pose joint_transform = jointTransform(body.joint, q.data() + body.q_index);
      data.parent_pose[i] = body.joint_placement * joint_transform;
      data.world_pose[i] = body.parent < 0 ? data.parent_pose[i]
                                           : data.world_pose[body.parent] * data.parent_pose[i];
      const double* vi = v ? v->data() + body.v_index : kZeroVelocity;
      jointMotion(body.joint, joint_transform, vi, data.motion_subspace[i],
                  data.bias_acceleration[i]);
      if (!v) continue;
      const MotionSubspace& S = data.motion_subspace[i];
      const Vector6 joint_velocity = S.apply(vi);
      data.velocity[i] = joint_velocity;
      if (body.parent >= 0)
        data.velocity[i] += data.parent_pose[i].motionToChild(data.velocity[body.parent]);
    }
  });
}

}  // namespace

void forwardKinematics(const Model& model, Data& data, const VectorX& q) {
  forwardPass(model, data, q, nullptr);
}

void forwardKinematics(const Model& model, Data& data, const VectorX& q, const VectorX& v) {
  forwardPass(model, data, q, &v);
}

}  // namespace sweep
