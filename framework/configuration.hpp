#pragma once
// Moving on the configuration manifold. Planar angles and joint angles are plain coordinates;
// floating bodies carry a unit quaternion (nq = 7, nv = 6), so these functions are the only
// correct way to add a velocity increment to q or to subtract two configurations.
#include <vector>

#include "framework/model.hpp"

namespace sweep {

// q_out = q (+) dv: every coordinate moves by dv as if v = dv were held for unit time
// (quaternions by the exponential map of the body-axes rotation vector).
// threads: the body trees on that many threads from kParallelItems trees on (parallel.hpp);
// components: those trees only, the others' coordinates copied from q (null: every tree)
void integrate(const Model& model, const VectorX& q, const VectorX& dv, VectorX& q_out,
               int threads = 1, const std::vector<int>* components = nullptr);
VectorX integrate(const Model& model, const VectorX& q, const VectorX& dv);

// dv such that q0 (+) dv = q1.
VectorX difference(const Model& model, const VectorX& q0, const VectorX& q1);

// qdot as a function of (q, v): the quaternion rate is 1/2 quat * (0, w_body).
void configurationRate(const Model& model, const VectorX& q, const VectorX& v, VectorX& qdot);

// Renormalizes every quaternion of q in place (threads, components: as integrate's).
void normalizeConfiguration(const Model& model, VectorX& q, int threads = 1,
                            const std::vector<int>* components = nullptr);

// Floating joints' velocities between Sweep's convention (linear velocity of the body origin
// in the parent frame, angular velocity in body axes) and the body-frame twist of Pinocchio's
// free flyer (both in body axes, linear first): the linear part is rotated by R(q)^T. DART's
// FreeJoint uses the same body-frame twist with the angular part first. Other joints' entries
// are copied.
VectorX velocityToBodyFrame(const Model& model, const VectorX& q, const VectorX& v);
VectorX velocityFromBodyFrame(const Model& model, const VectorX& q, const VectorX& v_body);

}  // namespace sweep
