#pragma once
// Candidate screening's predictions (SchemeSettings::screening): the normal velocity of a
// contact between root bodies from their world twists, without its Jacobian rows. Shared by
// the assembly's screening and the check of the contacts left out after the solve.
// Internal to integrators/.
#include <array>
#include <vector>

#include "contact/detection.hpp"
#include "framework/data.hpp"
#include "framework/model.hpp"
#include "framework/parallel.hpp"

namespace sweep {

// World twist (angular velocity, velocity of the origin) of each root body at v, from the
// motion subspaces of data (body frame, as the Jacobian's columns); bodies with a parent, and
// those of trees outside data's component subset, are left as they are and never read.
inline void rootBodyTwists(const Model& model, const Data& data, const VectorX& v,
                           std::vector<Vector6>& twists, int threads) {
  twists.resize(model.bodies.size());
  auto twist = [&](long b) {
    if (model.bodies[b].parent >= 0) return;
    const Vector6 local = data.motion_subspace[b].apply(v.data() + model.bodies[b].v_index);
    const Matrix3& R = data.world_pose[b].rotation;
    twists[b].head<3>() = R * local.head<3>();
    twists[b].tail<3>() = R * local.tail<3>();
  };
  if (const std::vector<int>* subset = data.componentSubset()) {  // the trees the step moves
    forEachBodyComponent(model, subset, threads,
                         [&](int c) { twist(model.components[c].first_body); });
    return;
  }
  forEachIndex(static_cast<long>(model.bodies.size()), threads, twist);
}

// Whether each side is a root body, a driven body or the world: then U_N follows from the
// bodies' world twists.
inline bool betweenRoots(const Model& model, const Contact& contact) {
  for (const BodyRef& body : {contact.body_a, contact.body_b})
    if (body.kind == BodyRef::Kind::Dynamic && model.bodies[body.index].parent >= 0) return false;
  return true;
}

// U_N of a contact from its bodies' world twists: the product of its Jacobian's normal row
// with v, without the rows, at `count` velocities at once (the normal and its moment about each
// body's origin are formed once). False when a side is a body with a parent (a link of a tree).
template <int count>
bool normalVelocitiesFromTwists(const Model& model, const Data& data, const Contact& contact,
                                const std::array<const std::vector<Vector6>*, count>& twists,
                                double t, std::array<double, count>& u) {
  u.fill(0.0);
  for (int side = 0; side < 2; ++side) {
    const BodyRef& body = side == 0 ? contact.body_a : contact.body_b;
    const Vector3& point = side == 0 ? contact.point_a : contact.point_b;
    const double sign = side == 0 ? -1.0 : 1.0;
    if (body.kind == BodyRef::Kind::Dynamic) {
      if (model.bodies[body.index].parent >= 0) return false;
      // n . (v + w x lever) = n . v + (lever x n) . w
      const Vector3 moment =
          (point - data.world_pose[body.index].translation).cross(contact.normal);
      for (int i = 0; i < count; ++i) {
        const Vector6& twist = (*twists[i])[body.index];
        u[i] += sign * (contact.normal.dot(twist.tail<3>()) + moment.dot(twist.head<3>()));
      }
    } else if (body.kind == BodyRef::Kind::Driven) {
      const double driven =
          sign * contact.normal.dot(model.driven_bodies[body.index].pointVelocity(point, t));
      for (int i = 0; i < count; ++i) u[i] += driven;
    }
  }
  return true;
}

}  // namespace sweep
