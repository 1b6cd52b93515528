#include "contact/contact_jacobian.hpp"

#include <cassert>

#include "contact/detection.hpp"
#include "framework/jacobian.hpp"
#include "framework/parallel.hpp"

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

namespace {

// The columns forEachPointJacobianColumn visits for a point of `body`: its chain's dofs
int chainColumns(const Model& model, const Data& data, int body) {
  int count = 0;
  for (int j = body; j >= 0; j = model.bodies[j].parent)
    count += model.bodies[j].joint.type == JointType::Floating
                 ? 6
                 : static_cast<int>(data.motion_subspace[j].cols());
  return count;
}

// The lowest body that is an ancestor of both a and b (each its own ancestor), -1 if none
int commonAncestor(const Model& model, int a, int b) {
  for (int i = a; i >= 0; i = model.bodies[i].parent)
    for (int j = b; j >= 0; j = model.bodies[j].parent)
      if (i == j) return i;
  return -1;
}

bool sameTree(const Model& model, const Contact& contact) {
  return contact.body_a.kind == BodyRef::Kind::Dynamic &&
         contact.body_b.kind == BodyRef::Kind::Dynamic &&
         model.bodies[contact.body_a.index].component ==
             model.bodies[contact.body_b.index].component;
}

}  // namespace

// Two passes, each on threads: every contact's entry count (a side's columns are its chain's
// dofs; two sides in one tree share their common ancestors' columns), then each contact's
// entries written at its own offset, with the arithmetic of a serial fill (every entry starts
// at 0 and takes side a's term, then side b's): the same bits for every thread count.
void assembleContactJacobian(const Model& model, const Data& data, const ContactModel& cmodel,
                             ContactData& cdata, double t, double max_gap,
                             const std::vector<char>* skip, int threads) {
  ContactJacobian& J = cdata.jacobian;
  J.dimension = cmodel.dimension;
  const int n = static_cast<int>(cdata.contacts.size());
  if (n < kParallelItems) threads = 1;
  J.begin.resize(n + 1);
  J.known_velocity.resize(n);
  J.rolling = cmodel.rolling;
  J.known_spin.resize(J.rolling ? n : 0);
  auto assembled = [&](int c) {
    return !(cdata.contacts[c].gap > max_gap || (skip != nullptr && (*skip)[c]));
  };
  parallelFor(n, threads, [&](int c) {
    int count = 0;
    if (assembled(c)) {
      const Contact& contact = cdata.contacts[c];
      for (const BodyRef& body : {contact.body_a, contact.body_b})
        if (body.kind == BodyRef::Kind::Dynamic) count += chainColumns(model, data, body.index);
      if (sameTree(model, contact)) {
        const int common = commonAncestor(model, contact.body_a.index, contact.body_b.index);
        if (common >= 0) count -= chainColumns(model, data, common);
      }
    }
    J.begin[c + 1] = count;
  });
  J.begin[0] = 0;
  for (int c = 0; c < n; ++c) J.begin[c + 1] += J.begin[c];
  const std::size_t entries = static_cast<std::size_t>(J.begin[n]);
  J.dof.resize(entries);
  J.normal.resize(entries);
  J.tangent1.resize(entries);
  J.tangent2.resize(entries);
  J.rolling1.resize(J.rolling ? entries : 0);
  J.rolling2.resize(J.rolling ? entries : 0);

  parallelFor(n, threads, [&](int c) {
    if (!assembled(c)) {
      J.known_velocity[c] = Vector3::Zero();
      if (J.rolling) J.known_spin[c] = Vector2::Zero();
      return;
    }
    const Contact& contact = cdata.contacts[c];
    Vector3 known = Vector3::Zero();
    Vector2 spin = Vector2::Zero();
    // rolling rows: the relative angular velocity about the tangents (3D) or the plane normal
    // (2D), the axes a rolling torque acts on
    const Vector3 roll1 = cmodel.dimension == 2 ? Vector3(Vector3::UnitZ()) : contact.tangent1;
    const Vector3 roll2 = cmodel.dimension == 2 ? Vector3(Vector3::Zero()) : contact.tangent2;
    // Two sides in different trees never share a dof, so their columns are appended as they
    // come; only a contact within one tree (self-collision) looks for the entry to merge into
    // among the contact's own (a chain of a few dofs).
    const bool one_tree = sameTree(model, contact);
    const int first = J.begin[c];
    int end = first;
    // U = velocity of b's point minus velocity of a's point, projected on the frame
    for (int side = 0; side < 2; ++side) {
      const BodyRef& body = side == 0 ? contact.body_a : contact.body_b;
      const Vector3& point = side == 0 ? contact.point_a : contact.point_b;
      const double sign = side == 0 ? -1.0 : 1.0;
      if (body.kind == BodyRef::Kind::Dynamic) {
        forEachPointJacobianColumn(model, data, body.index, point,
                                   [&](int v_index, const Vector3& angular, const Vector3& linear) {
                                     int slot = end;
                                     if (one_tree && side == 1)
                                       for (int k = first; k < end; ++k)
                                         if (J.dof[k] == v_index) slot = k;
                                     if (slot == end) {
                                       ++end;
                                       J.dof[slot] = v_index;
                                       J.normal[slot] = J.tangent1[slot] = J.tangent2[slot] = 0.0;
                                       if (J.rolling) J.rolling1[slot] = J.rolling2[slot] = 0.0;
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
    assert(end == J.begin[c + 1]);  // the counting pass's count
    J.known_velocity[c] = known;
    if (J.rolling) J.known_spin[c] = spin;
  });
}

}  // namespace sweep
