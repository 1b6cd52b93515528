#pragma once
// Step 3 (shared part): the rows W_N, W_T of every contact over the generalized velocities v,
// stored sparse. Row c touches only the dofs that move its two witness points: the dofs of
// the two bodies and, for links of a tree, of their ancestors.
//
//   U_N = W_N^T v + known_velocity.x()   relative normal velocity at the contact
//   U_T = W_T^T v + known_velocity.(y,z) relative tangential velocities
//
// where known_velocity carries the motion of kinematically driven bodies (zero if none).
#include <limits>
#include <vector>

#include "framework/data.hpp"

namespace sweep {

struct Contact;
struct ContactModel;
struct ContactData;

struct ContactJacobian {
  int dimension = 3;                    // 2: one tangent (tangent2 entries are zero and unused)
  std::vector<int> begin;               // entries of contact c: [begin[c], begin[c + 1])
  std::vector<int> dof;                 // velocity index of each entry
  std::vector<double> normal;           // W_N entries
  std::vector<double> tangent1;         // W_T entries, first tangent
  std::vector<double> tangent2;         // W_T entries, second tangent (3D)
  std::vector<Vector3> known_velocity;  // (normal, tangent1, tangent2) relative velocity at v = 0
  // rolling rows, filled when some law has rolling resistance: the relative angular velocity
  // (omega_b - omega_a) about tangent1 and tangent2 (3D), or about z (2D, rolling2 zero)
  bool rolling = false;
  std::vector<double> rolling1, rolling2;
  std::vector<Vector2> known_spin;  // the same at v = 0 (driven bodies: a spinning roller)

  int size() const { return static_cast<int>(known_velocity.size()); }

  // relative velocity of contact c in its frame (normal, tangent1, tangent2)
  Vector3 relativeVelocity(int c, const Eigen::VectorXd& v) const {
    Vector3 u = known_velocity[c];
    for (int k = begin[c]; k < begin[c + 1]; ++k) {
      const double vk = v[dof[k]];
      u.x() += normal[k] * vk;
      u.y() += tangent1[k] * vk;
      u.z() += tangent2[k] * vk;
    }
    return u;
  }
};

// What a driven body on one side of a contact (sign -1: side a, +1: side b) adds to the
// contact's relative velocity at v = 0, at time t: known (normal, tangent1, tangent2) and spin
// (its angular velocity about roll1, roll2). `point` is the contact point on that side.
void addDrivenVelocity(const DrivenBody& driven, const Contact& contact, const Vector3& point,
                       const Vector3& roll1, const Vector3& roll2, double sign, double t,
                       Vector3& known, Vector2& spin);

// Needs the kinematics of `data` at the detection configuration; driven bodies move with
// their velocity at `t`. Contacts with gap > max_gap get no entries and zero known
// velocities: a solve that takes closed contacts only (the VEL law) does not need the
// rows of the open candidates, which in a granular heap outnumber the closed ones 2.5 to 1.
// skip (when given, one flag per contact): contacts that get no entries either. On `threads`
// threads from kParallelItems contacts on, the same bits for every count.
void assembleContactJacobian(const Model& model, const Data& data, const ContactModel& cmodel,
                             ContactData& cdata, double t,
                             double max_gap = std::numeric_limits<double>::infinity(),
                             const std::vector<char>* skip = nullptr, int threads = 1);

}  // namespace sweep
