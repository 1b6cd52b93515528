// The contact problem's rows written one by one (integrators/contact_assembly.hpp): from
// Jacobian entries (with M^-1 H and W_cc), in body form, or as compact sphere rows, each with
// the same tail (inverse, velocities, bias, rolling row).
#include <algorithm>
#include <cmath>

#include "integrators/contact_assembly.hpp"

namespace sweep {

void ProblemAssembly::diagonalDelassus(int pc, Matrix3& W, Matrix2& W_r) {
  double w[3][3] = {}, w_r[2][2] = {};
  p.forEachDiagonalEntry(pc, [&](int, const Vector3& h, const Vector2& h_r, double inverse_mass) {
    for (int i = 0; i < 3; ++i) {
      const double scaled = inverse_mass * h[i];
      for (int j = 0; j < 3; ++j) w[i][j] += scaled * h[j];
    }
    if (p.rolling) {
      for (int i = 0; i < 2; ++i) {
        const double scaled = inverse_mass * h_r[i];
        for (int j = 0; j < 2; ++j) w_r[i][j] += scaled * h_r[j];
      }
    }
  });
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) W(i, j) = w[i][j];
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) W_r(i, j) = w_r[i][j];
}

void ProblemAssembly::finishRowTail(int pc, const std::vector<int>& touched, Matrix3 W, Matrix2 W_r,
                                    const Vector3& known, double gap, double mu, double e,
                                    const Vector2& known_spin, double rolling_bound,
                                    bool diagonal_W) {
  ws.row_component[pc] = touched.front();
  std::array<int, 2> moved{touched.front(), -1};
  for (int comp : touched) {
    if (comp == moved[0] || comp == moved[1]) continue;
    moved = moved[1] < 0 ? std::array<int, 2>{moved[0], comp} : std::array<int, 2>{-2, -2};
    if (moved[0] == -2) break;
  }
  p.row_components[pc] = moved;

  if (p.dimension == 2) {
    W.row(2).setZero();
    W.col(2).setZero();
  }
  p.delassus[pc] = W;
  // a row without friction (mu = 0, or no tangential motion at all, as a joint limit)
  // is solved on its normal alone: its tangential block may be singular
  const double W_TT = p.dimension == 2 ? W(1, 1) : W(1, 1) + W(2, 2);
  if (!(W_TT > 1e-12 * W(0, 0))) mu = 0.0;
  Matrix3 W_inverse = Matrix3::Zero();
  if (mu == 0.0)
    W_inverse(0, 0) = 1.0 / W(0, 0);
  else if (diagonal_W)
    W_inverse.diagonal() = W.diagonal().cwiseInverse();
  else if (p.dimension == 2)
    W_inverse.topLeftCorner<2, 2>() = W.topLeftCorner<2, 2>().inverse();
  else
    W_inverse = W.inverse();
  p.delassus_inverse[pc] = W_inverse;
  p.normal_compliance_inverse[pc] = 1.0 / W(0, 0);
  p.known[pc] = known;
  p.gap[pc] = gap;
  p.friction[pc] = mu;
  p.restitution[pc] = e;
  const Vector3 u_start = p.localVelocity(pc, v_start);
  p.velocity_start[pc] = u_start;
  p.normal_bias[pc] = normalBias(law, e, u_start.x(), gap, tau);
  // VEL's open adhesive rows (closedForVel) may close their gap within the step, as under IQS
  if (law == NormalLaw::Vel && cmodel.adhesive() && gap > heldGap(cmodel))
    p.normal_bias[pc] += gap / tau;
  if (p.rolling) {
    if (p.dimension == 2) W_r(1, 1) = W_r(0, 0);  // keeps the unused axis inert, not singular
    // a pair whose bodies cannot turn (no rotational inertia reached) has no rolling row
    if (!(W_r(0, 0) > 0.0 && W_r(1, 1) > 0.0)) rolling_bound = 0.0;
    p.rolling_delassus[pc] = W_r;
    p.rolling_known[pc] = known_spin;
    p.rolling_bound[pc] = rolling_bound;
  }
}

void ProblemAssembly::finishEntryRow(int pc, const std::vector<int>& touched, bool diagonal_row,
                                     const Vector3& known, double gap, double mu, double e,
                                     const Vector2& known_spin, double rolling_bound,
                                     ContactProblemWorkspace::EntryRowScratch& scratch) {
  p.row_body_form[pc] = -1;
  p.row_sphere[pc] = -1;
  p.diagonal[pc] = diagonal_row ? 1 : 0;
  Matrix3 W = Matrix3::Zero();
  Matrix2 W_r = Matrix2::Zero();
  if (diagonal_row) {
    // M^-1 H is H scaled entry by entry: no M^-1 H entries are stored (h_inverse_mass)
    for (int k = p.begin[pc]; k < p.begin[pc + 1]; ++k)
      p.h_inverse_mass[k] = data.constant_inverse_diagonal[p.dof[k]];
    diagonalDelassus(pc, W, W_r);
  } else {
    for (int k = p.begin[pc]; k < p.begin[pc + 1]; ++k) p.h_inverse_mass[k] = 0.0;
    int slot = p.minv_begin[pc];
    for (int comp : touched) {
      const Component& component = model.components[comp];
      if (data.has_constant_inverse6[comp]) {
        // a free body in a row with a tree, or off its principal axes: fixed-size work
        Eigen::Matrix<double, 6, 5> rhs = Eigen::Matrix<double, 6, 5>::Zero();
        for (int k = p.begin[pc]; k < p.begin[pc + 1]; ++k) {
          if (ws.dof_component[p.dof[k]] != comp) continue;
          const int i = p.dof[k] - component.v_index;
          rhs.row(i).head<3>() = p.h[k].transpose();
          if (p.rolling) rhs.row(i).tail<2>() = p.rolling_h[k].transpose();
        }
        Eigen::Matrix<double, 6, 5> solved;
        if (data.constant_inverse6_diagonal[comp])
          solved = data.constant_inverse6[comp].diagonal().asDiagonal() * rhs;
        else
          solved.noalias() = data.constant_inverse6[comp] * rhs;
        for (int i = 0; i < 6; ++i, ++slot) {
          p.minv_dof[slot] = component.v_index + i;
          p.minv_h[slot] = Vector3(solved(i, 0), solved(i, 1), solved(i, 2));
          if (p.rolling) p.rolling_minv_h[slot] = Vector2(solved(i, 3), solved(i, 4));
        }
        continue;
      }
      auto solve = [&](auto& solved) {
        solved.setZero(component.nv, rhs_columns);
        for (int k = p.begin[pc]; k < p.begin[pc + 1]; ++k) {
          if (ws.dof_component[p.dof[k]] != comp) continue;
          const int i = p.dof[k] - component.v_index;
          solved.row(i).template head<3>() = p.h[k].transpose();
          if (p.rolling) solved.row(i).template tail<2>() = p.rolling_h[k].transpose();
        }
        if (data.constant_small_diagonal[comp]) {
          for (int i = 0; i < component.nv; ++i)
            solved.row(i) *= data.small_inverse_diagonal[component.v_index + i];
        } else {
          data.mass_factors[comp].solveInPlace(solved);
        }
        for (int i = 0; i < component.nv; ++i, ++slot) {
          p.minv_dof[slot] = component.v_index + i;
          p.minv_h[slot] = Vector3(solved(i, 0), solved(i, 1), solved(i, 2));
          if (p.rolling) p.rolling_minv_h[slot] = Vector2(solved(i, 3), solved(i, 4));
        }
      };
      if (component.nv <= 6)
        solve(scratch.rhs);
      else
        solve(ws.component_rhs[comp]);
    }
    // W_cc = H_c^T M^-1 H_c
    for (int m = p.minv_begin[pc]; m < p.minv_begin[pc + 1]; ++m)
      scratch.minv_slot[p.minv_dof[m]] = m;
    for (int k = p.begin[pc]; k < p.begin[pc + 1]; ++k) {
      const int m = scratch.minv_slot[p.dof[k]];
      if (m < 0) continue;
      W += p.h[k] * p.minv_h[m].transpose();
      if (p.rolling) W_r += p.rolling_h[k] * p.rolling_minv_h[m].transpose();
    }
    for (int m = p.minv_begin[pc]; m < p.minv_begin[pc + 1]; ++m)
      scratch.minv_slot[p.minv_dof[m]] = -1;
  }
  finishRowTail(pc, touched, W, W_r, known, gap, mu, e, known_spin, rolling_bound);
}

void ProblemAssembly::bodyFormRow(int pc, const Contact& contact, std::vector<int>& touched) {
  p.diagonal[pc] = 1;
  // filled in place: a record is six cache lines, and a copy of it cost as much as the fill
  ContactProblem::PackedBodies3d& b = p.bodies3d[p.row_body_form[pc]];
  b = ContactProblem::PackedBodies3d{};
  Vector3 known = Vector3::Zero();
  Vector2 spin = Vector2::Zero();
  const Vector3& roll1 = contact.tangent1;
  const Vector3& roll2 = contact.tangent2;
  touched.clear();
  forEachSide(contact, known, spin, [&](int index, const Vector3& point, double sign) {
    const Body& body = model.bodies[index];
    const Pose& pose = data.world_pose[index];
    const Vector3 lever = point - pose.translation;
    const bool first = touched.empty();
    touched.push_back(body.component);
    const double* inverse = data.constant_inverse_diagonal.data() + body.v_index;
    // block b's linear coefficients are block a's negated: not stored
    if (first) {
      const Matrix3& frame = body.joint_placement.rotation;
      for (int k = 0; k < 3; ++k) {
        const Vector3 linear = frame.col(k).eval();
        b.translation_normal[k] = 0.0 + sign * contact.normal.dot(linear);
        b.translation[0][k] = 0.0 + sign * contact.tangent1.dot(linear);
        b.translation[1][k] = 0.0 + sign * contact.tangent2.dot(linear);
      }
      b.dof_a = body.v_index;
      b.inverse_mass_a = inverse[0];
    } else {
      b.dof_b = body.v_index;
      b.inverse_mass_b = inverse[0];
    }
    double(&normal)[3] = first ? b.rotation_normal_a : b.rotation_normal_b;
    double(&rest)[4][3] = first ? b.rotation_a : b.rotation_b;
    double(&inertia)[3] = first ? b.inverse_inertia_a : b.inverse_inertia_b;
    for (int k = 0; k < 3; ++k) {
      const Vector3 w = pose.rotation.col(k);
      const Vector3 linear = w.cross(lever).eval();
      normal[k] = 0.0 + sign * contact.normal.dot(linear);
      rest[0][k] = 0.0 + sign * contact.tangent1.dot(linear);
      rest[1][k] = 0.0 + sign * contact.tangent2.dot(linear);
      if (p.rolling) {
        rest[2][k] = 0.0 + sign * roll1.dot(w);
        rest[3][k] = 0.0 + sign * roll2.dot(w);
      }
      inertia[k] = inverse[3 + k];
    }
  });
  Matrix3 W;
  Matrix2 W_r;
  diagonalDelassus(pc, W, W_r);  // as for the same row in entry form
  finishRowTail(pc, touched, W, W_r, known, contact.gap, contact.friction, contact.restitution,
                spin, contact.rolling);
}

void ProblemAssembly::sphereRow(int pc, const Contact& contact, std::vector<int>& touched) {
  p.diagonal[pc] = 1;
  ContactProblem::PackedSphere3d& s = p.spheres3d[p.row_sphere[pc]];
  s = ContactProblem::PackedSphere3d{};
  Vector3 known = Vector3::Zero();
  Vector2 spin = Vector2::Zero();
  touched.clear();
  forEachSide(contact, known, spin, [&](int index, const Vector3& point, double sign) {
    const ContactProblemWorkspace::SphereParticle& body = ws.sphere_particles[index];
    const Pose& pose = data.world_pose[index];
    const bool first = touched.empty();
    touched.push_back(body.component);
    const double lever = (point - pose.translation).dot(contact.normal);
    const Vector3 axis1 = sign * (pose.rotation.transpose() * contact.tangent1);
    const Vector3 axis2 = sign * (pose.rotation.transpose() * contact.tangent2);
    double(&axes)[2][3] = first ? s.axes_a : s.axes_b;
    for (int k = 0; k < 3; ++k) {
      axes[0][k] = axis1[k];
      axes[1][k] = axis2[k];
    }
    if (first) {
      for (int k = 0; k < 3; ++k) {
        s.normal[k] = sign * contact.normal[k];
        s.tangent[0][k] = sign * contact.tangent1[k];
        s.tangent[1][k] = sign * contact.tangent2[k];
      }
      s.dof_a = body.v_index;
      s.lever_a = lever;
      s.inverse_mass_a = body.inverse_mass;
      s.inverse_inertia_a = body.inverse_inertia;
    } else {
      s.dof_b = body.v_index;
      s.lever_b = lever;
      s.inverse_mass_b = body.inverse_mass;
      s.inverse_inertia_b = body.inverse_inertia;
    }
  });
  // the record's velocities before the tail, which reads the start velocity through it
  for (int k = 0; k < 3; ++k) s.known[k] = known[k];
  s.rolling_known[0] = spin.x();
  s.rolling_known[1] = spin.y();
  const Matrix3 W = Vector3(s.W_N(), s.W_T(), s.W_T()).asDiagonal();
  Matrix2 W_r = Matrix2::Zero();
  if (p.rolling) W_r.diagonal().setConstant(s.inverse_inertia_a + s.inverse_inertia_b);
  finishRowTail(pc, touched, W, W_r, known, contact.gap, contact.friction, contact.restitution,
                spin, contact.rolling, true);
  s.bias = p.normal_bias[pc];
  s.mu = p.friction[pc];
  s.normal_inverse = p.delassus_inverse[pc](0, 0);
  s.tangent_inverse = p.delassus_inverse[pc](1, 1);
  if (p.rolling && p.rolling_bound[pc] > 0.0) {
    s.rolling_bound = p.rolling_bound[pc];
    s.rolling_inverse = 1.0 / W_r(0, 0);
  }
}

void ProblemAssembly::contactEntryRow(int pc, int c, std::vector<int>& touched,
                                      ContactProblemWorkspace::EntryRowScratch& scratch) {
  const Contact& contact = cdata.contacts[c];
  for (int k = J.begin[c], e = p.begin[pc]; k < J.begin[c + 1]; ++k, ++e) {
    p.dof[e] = J.dof[k];
    p.h[e] = Vector3(J.normal[k], J.tangent1[k], J.tangent2[k]);
    if (p.rolling) p.rolling_h[e] = Vector2(J.rolling1[k], J.rolling2[k]);
  }
  const bool diagonal_row =
      entryComponents(&J.dof[J.begin[c]], J.begin[c + 1] - J.begin[c], touched);
  finishEntryRow(pc, touched, diagonal_row, J.known_velocity[c], contact.gap, contact.friction,
                 contact.restitution, p.rolling ? J.known_spin[c] : Vector2::Zero(),
                 contact.rolling, scratch);
}

}  // namespace sweep
