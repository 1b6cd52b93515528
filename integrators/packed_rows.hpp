#pragma once
// Reads of the packed 3D rows (ContactProblem::pack3d): the velocities a row sees and the
// velocity change its impulse makes. Shared by the sweeps (integrators/nlgs.cpp), which must
// inline them, and the stepper's diagnostics (contact work), which must give the same sums.
#include "integrators/contact_problem.hpp"

namespace sweep {

// The packed 3D rows' storage, for the updates below
struct PackedRows3d {
  const ContactProblem::PackedRow3d* rows;
  const ContactProblem::PackedEntry3d* h;
  const ContactProblem::PackedEntry3d* minv;
  const ContactProblem::PackedBodies3d* bodies;
  const ContactProblem::PackedSphere3d* spheres;
  const int* slot;  // per row: its PackedRow3d (>= 0) or sphere record (-1 - index)
  explicit PackedRows3d(const ContactProblem& p)
      : rows(p.rows3d.data()),
        h(p.h3d.data()),
        minv(p.minv3d.data()),
        bodies(p.bodies3d.data()),
        spheres(p.spheres3d.data()),
        slot(p.packed_slot.data()) {}
};

// The three functions below read a row in body form in its entries' order (block a's linear
// then angular velocities, then block b's), and subtract where block b's coefficient is block
// a's negated: (-x) * y is -(x * y) exactly, so both forms give the same bits.

// U_N = H_N^T v + known_N alone
[[gnu::always_inline]] inline double packedNormalVelocity3d(const ContactProblem::PackedRow3d& r,
                                                            const PackedRows3d& s,
                                                            const VectorX& v) {
  double u = r.known.x();
  if (r.body_form < 0) {
    for (int k = r.begin; k < r.end; ++k) u += s.h[k].normal * v[s.h[k].dof];
    return u;
  }
  const ContactProblem::PackedBodies3d& b = s.bodies[r.body_form];
  const double* va = v.data() + b.dof_a;
  for (int i = 0; i < 3; ++i) u += b.translation_normal[i] * va[i];
  for (int i = 0; i < 3; ++i) u += b.rotation_normal_a[i] * va[3 + i];
  if (b.dof_b < 0) return u;
  const double* vb = v.data() + b.dof_b;
  for (int i = 0; i < 3; ++i) u -= b.translation_normal[i] * vb[i];
  for (int i = 0; i < 3; ++i) u += b.rotation_normal_b[i] * vb[3 + i];
  return u;
}

// (U_c, U_r) = H^T v + known on a packed 3D row: one pass over its entries
[[gnu::always_inline]] inline void packedVelocity3d(const ContactProblem::PackedRow3d& r,
                                                    const PackedRows3d& s, const VectorX& v,
                                                    Vector3& u, Vector2& u_rolling) {
  u = r.known;
  u_rolling = r.rolling_known;
  if (r.body_form < 0) {
    for (int k = r.begin; k < r.end; ++k) {
      const ContactProblem::PackedEntry3d& e = s.h[k];
      const double vk = v[e.dof];
      u.x() += e.normal * vk;
      u.y() += e.tangent1 * vk;
      u.z() += e.tangent2 * vk;
      u_rolling.x() += e.rolling1 * vk;
      u_rolling.y() += e.rolling2 * vk;
    }
    return;
  }
  const ContactProblem::PackedBodies3d& b = s.bodies[r.body_form];
  // inlined with `negated` a constant: the sweeps' hot path (docs/powder_bed.md)
  auto block = [&](const double* vblock, bool negated, const double(&rotation_normal)[3],
                   const double(&rotation)[4][3]) __attribute__((always_inline)) {
    for (int i = 0; i < 3; ++i) {
      const double vk = vblock[i];
      if (negated) {
        u.x() -= b.translation_normal[i] * vk;
        u.y() -= b.translation[0][i] * vk;
        u.z() -= b.translation[1][i] * vk;
      } else {
        u.x() += b.translation_normal[i] * vk;
        u.y() += b.translation[0][i] * vk;
        u.z() += b.translation[1][i] * vk;
      }
    }
    for (int i = 0; i < 3; ++i) {
      const double vk = vblock[3 + i];
      u.x() += rotation_normal[i] * vk;
      u.y() += rotation[0][i] * vk;
      u.z() += rotation[1][i] * vk;
      u_rolling.x() += rotation[2][i] * vk;
      u_rolling.y() += rotation[3][i] * vk;
    }
  };
  block(v.data() + b.dof_a, false, b.rotation_normal_a, b.rotation_a);
  if (b.dof_b >= 0) block(v.data() + b.dof_b, true, b.rotation_normal_b, b.rotation_b);
}

// v += M^-1 (H_c dP + H_r dR) on a packed 3D row
[[gnu::always_inline]] inline void applyPacked3d(const ContactProblem::PackedRow3d& r,
                                                 const PackedRows3d& s, const Vector3& dP,
                                                 const Vector2& dR, VectorX& v) {
  if (r.body_form >= 0) {
    const ContactProblem::PackedBodies3d& b = s.bodies[r.body_form];
    double translation[3];
    for (int i = 0; i < 3; ++i)
      translation[i] = b.translation_normal[i] * dP.x() + b.translation[0][i] * dP.y() +
                       b.translation[1][i] * dP.z();
    auto block = [&](double* vblock, double inverse_mass, bool negated,
                     const double(&rotation_normal)[3], const double(&rotation)[4][3],
                     const double(&inverse_inertia)[3]) __attribute__((always_inline)) {
      for (int i = 0; i < 3; ++i) {
        if (negated)
          vblock[i] -= inverse_mass * translation[i];
        else
          vblock[i] += inverse_mass * translation[i];
      }
      for (int i = 0; i < 3; ++i)
        vblock[3 + i] += inverse_inertia[i] * (rotation_normal[i] * dP.x() +
                                               rotation[0][i] * dP.y() + rotation[1][i] * dP.z() +
                                               rotation[2][i] * dR.x() + rotation[3][i] * dR.y());
    };
    block(v.data() + b.dof_a, b.inverse_mass_a, false, b.rotation_normal_a, b.rotation_a,
          b.inverse_inertia_a);
    if (b.dof_b >= 0)
      block(v.data() + b.dof_b, b.inverse_mass_b, true, b.rotation_normal_b, b.rotation_b,
            b.inverse_inertia_b);
    return;
  }
  if (r.minv_begin == r.minv_end) {  // a diagonal row: M^-1 H is H scaled
    for (int k = r.begin; k < r.end; ++k) {
      const ContactProblem::PackedEntry3d& e = s.h[k];
      v[e.dof] += e.inverse_mass * (e.normal * dP.x() + e.tangent1 * dP.y() + e.tangent2 * dP.z() +
                                    e.rolling1 * dR.x() + e.rolling2 * dR.y());
    }
    return;
  }
  for (int k = r.minv_begin; k < r.minv_end; ++k) {
    const ContactProblem::PackedEntry3d& e = s.minv[k];
    v[e.dof] += e.normal * dP.x() + e.tangent1 * dP.y() + e.tangent2 * dP.z() +
                e.rolling1 * dR.x() + e.rolling2 * dR.y();
  }
}

// (U_c, U_r) of row c, whichever packed form it has
[[gnu::always_inline]] inline void packedRowVelocity3d(const PackedRows3d& s, int c,
                                                       const VectorX& v, Vector3& u,
                                                       Vector2& u_rolling) {
  const int slot = s.slot[c];
  if (slot < 0)
    s.spheres[-1 - slot].velocity(v, u, u_rolling);
  else
    packedVelocity3d(s.rows[slot], s, v, u, u_rolling);
}

}  // namespace sweep
