#include "contact/contact_jacobian.hpp"

#include "contact/detection.hpp"
#include "framework/jacobian.hpp"

namespace sweep {

void addDrivenVelocity(const DrivenBody& driven, const Contact& contact, const Vector3& point,
                       const Vector3& roll1, const Vector3& roll2, double sign, double t,
                       Vector3& known, Vector2& spin) {
  const Vector6 twist = driven.twist(t);
  const Vector3 velocity = driven.pointVelocity(point, t);
  known += sign * Vector3(contact.normal.dot(velocity), contact.tangent1.dot(velocity),
                          contact.tangent2.dot(velocity));
  spin += sign * Vector2(roll1.dot(twist.head<3>()), roll2.dot(twist.head<3>()));
}

void assembleContactJacobian(const Model& model, const Data& data, const ContactModel& cmodel,
                             ContactData& cdata, double t, double max_gap,
                             const std::vector<char>* skip) {
  ContactJacobian& J = cdata.jacobian;
  J.dimension = cmodel.dimension;
  const int n = static_cast<int>(cdata.contacts.size());
  J.begin.resize(n + 1);
  J.known_velocity.resize(n);
  J.dof.clear();
  J.normal.clear();
  J.tangent1.clear();
  J.tangent2.clear();
  J.rolling = cmodel.rolling;
  J.rolling1.clear();
  J.rolling2.clear();
  J.known_spin.resize(J.rolling ? n : 0);

  for (int c = 0; c < n; ++c) {
    const Contact& contact = cdata.contacts[c];
    J.begin[c] = static_cast<int>(J.dof.size());
    if (contact.gap > max_gap || (skip != nullptr && (*skip)[c])) {
      J.known_velocity[c] = Vector3::Zero();
      if (J.rolling) J.known_spin[c] = Vector2::Zero();
      continue;
    }
    Vector3 known = Vector3::Zero();
    Vector2 spin = Vector2::Zero();
    // rolling rows: the relative angular velocity about the tangents (3D) or the plane normal
    // (2D), the axes a rolling torque acts on
    const Vector3 roll1 = cmodel.dimension == 2 ? Vector3(Vector3::UnitZ()) : contact.tangent1;
    const Vector3 roll2 = cmodel.dimension == 2 ? Vector3(Vector3::Zero()) : contact.tangent2;
    // Two sides in different trees never share a dof, so their columns are appended as they
    // come; only a contact within one tree (self-collision) needs the slot lookup that merges
    // them. A powder bed's 500 000 candidates spend a quarter of the step here.
    const bool one_tree = contact.body_a.kind == BodyRef::Kind::Dynamic &&
                          contact.body_b.kind == BodyRef::Kind::Dynamic &&
                          model.bodies[contact.body_a.index].component ==
                              model.bodies[contact.body_b.index].component;
    // U = velocity of b's point minus velocity of a's point, projected on the frame
    for (int side = 0; side < 2; ++side) {
      const BodyRef& body = side == 0 ? contact.body_a : contact.body_b;
      const Vector3& point = side == 0 ? contact.point_a : contact.point_b;
      const double sign = side == 0 ? -1.0 : 1.0;
      if (body.kind == BodyRef::Kind::Dynamic) {
        forEachPointJacobianColumn(model, data, body.index, point,
                                   [&](int v_index, const Vector3& angular, const Vector3& linear) {
                                     int unmerged = -1;
                                     int& slot = one_tree ? cdata.dof_slot[v_index] : unmerged;
                                     if (slot < 0) {
                                       slot = static_cast<int>(J.dof.size());
                                       J.dof.push_back(v_index);
                                       J.normal.push_back(0.0);
                                       J.tangent1.push_back(0.0);
                                       J.tangent2.push_back(0.0);
                                       if (J.rolling) {
                                         J.rolling1.push_back(0.0);
                                         J.rolling2.push_back(0.0);
                                       }
                                     }
                                     J.normal[slot] += sign * contact.normal.dot(linear);
                                     J.tangent1[slot] += sign * contact.tangent1.dot(linear);
                                     J.tangent2[slot] += sign * contact.tangent2.dot(linear);
                                     if (J.rolling) {
                                       J.rolling1[slot] += sign * roll1.dot(angular);
                                       J.rolling2[slot] += sign * roll2.dot(angular);
                                     }
                                   });
      } else if (body.kind == BodyRef::Kind::Driven) {
        addDrivenVelocity(model.driven_bodies[body.index], contact, point, roll1, roll2, sign, t,
                          known, spin);
      }
    }
    if (one_tree)
      for (int k = J.begin[c]; k < static_cast<int>(J.dof.size()); ++k)
        cdata.dof_slot[J.dof[k]] = -1;
    J.known_velocity[c] = known;
    if (J.rolling) J.known_spin[c] = spin;
  }
  J.begin[n] = static_cast<int>(J.dof.size());
}

}  // namespace sweep
