#include "framework/rnea.hpp"

#include "framework/crba.hpp"
#include "framework/kinematics.hpp"
#include "framework/parallel.hpp"

namespace sweep {

namespace {

// the RNEA passes, on poses and velocities already computed by forwardKinematics(q, v)
const VectorX& rneaPasses(const Model& model, Data& data, const VectorX& v, const VectorX* a,
                          bool gravity = true) {
  Vector6 base_acceleration;
  base_acceleration << Vector3::Zero(), gravity ? Vector3(-model.gravity) : Vector3::Zero();

  // tree by tree: the forward pass in body order, the backward pass in reverse
  forEachBodyComponent(model, data.componentSubset(), data.threads, [&](int c) {
    const Component& comp = model.components[c];
    // forward: a_i = X_i a_parent + S_i qdd_i + c_J + v_i x (S_i qd_i);  f_i = I a + v x* I v
    for (int i = comp.first_body; i < comp.end_body; ++i) {
      const Body& body = model.bodies[i];
      const MotionSubspace& S = data.motion_subspace[i];
      const Vector6 joint_velocity = S.apply(v.data() + body.v_index);
      const Vector6& parent_acceleration =
          body.parent < 0 ? base_acceleration : data.acceleration[body.parent];
      Vector6 acc = data.parent_pose[i].motionToChild(parent_acceleration) +
                    data.bias_acceleration[i] + crossMotion(data.velocity[i], joint_velocity);
      if (a) acc += S.apply(a->data() + body.v_index);
      data.acceleration[i] = acc;
      const Inertia& inertia = body.inertia;
      data.force[i] =
          inertia.apply(acc) + crossForce(data.velocity[i], inertia.apply(data.velocity[i]));
    }
    // backward: tau_i = S_i^T f_i, f_parent += X_i^* f_i
    for (int i = comp.end_body - 1; i >= comp.first_body; --i) {
      const Body& body = model.bodies[i];
      const MotionSubspace& S = data.motion_subspace[i];
      S.applyTranspose(data.force[i], data.tau.data() + body.v_index);
      if (body.parent >= 0)
        data.force[body.parent] += data.parent_pose[i].forceToParent(data.force[i]);
    }
  });
  // systems by their equations: no bias of their own (their forces are applied forces), and
  // M(q) a for inverse dynamics
  for (std::size_t c = 0; c < model.components.size(); ++c) {
    const Component& comp = model.components[c];
    if (comp.system < 0) continue;
    if (a)
      data.tau.segment(comp.v_index, comp.nv) =
          systemMass(model, static_cast<int>(c), data.q) * a->segment(comp.v_index, comp.nv);
    else
      data.tau.segment(comp.v_index, comp.nv).setZero();
  }
  return data.tau;
}

}  // namespace

const VectorX& rnea(const Model& model, Data& data, const VectorX& q, const VectorX& v,
                    const VectorX& a) {
  forwardKinematics(model, data, q, v);
  return rneaPasses(model, data, v, &a);
}

const VectorX& biasForces(const Model& model, Data& data, const VectorX& q, const VectorX& v) {
  forwardKinematics(model, data, q, v);
  return rneaPasses(model, data, v, nullptr);
}

const VectorX& gravityForces(const Model& model, Data& data, const VectorX& q) {
  // at v = 0: the passes read the velocities and c_J the kinematics leave
  const VectorX zero = VectorX::Zero(model.nv);
  forwardKinematics(model, data, q, zero);
  return rneaPasses(model, data, zero, nullptr);
}

const VectorX& coriolisForces(const Model& model, Data& data, const VectorX& q, const VectorX& v) {
  forwardKinematics(model, data, q, v);
  return rneaPasses(model, data, v, nullptr, /*gravity=*/false);
}

const VectorX& biasForcesFromKinematics(const Model& model, Data& data, const VectorX& v) {
  return rneaPasses(model, data, v, nullptr);
}

void computeAllTerms(const Model& model, Data& data, const VectorX& q, const VectorX& v) {
  forwardKinematics(model, data, q, v);
  rneaPasses(model, data, v, nullptr);
  computeMassBlocks(model, data, /*include_constant=*/false);
}

}  // namespace sweep
