#include "integrators/contact_problem.hpp"

#include <omp.h>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <stdexcept>
#include <string>

#include "contact/detection.hpp"
#include "framework/parallel.hpp"

namespace sweep {

const char* normalLawName(NormalLaw law) {
  switch (law) {
    case NormalLaw::Vel:
      return "VEL";
    case NormalLaw::Iqs:
      return "IQS";
    case NormalLaw::Pos:
      return "POS";
  }
  return "?";
}

ContactProblemWorkspace::ContactProblemWorkspace(const Model& model)
    : component_rhs(model.components.size()),
      dof_component(model.nv, 0),
      component_parent(model.components.size()),
      island_of_root(model.components.size()),
      minv_slot(model.nv, -1) {
  for (std::size_t i = 0; i < model.components.size(); ++i) {
    const Component& component = model.components[i];
    component_rhs[i] = MatrixX::Zero(component.nv, 3);
    for (int k = 0; k < component.nv; ++k)
      dof_component[component.v_index + k] = static_cast<int>(i);
  }
}

void ContactProblem::pack2d() {
  rows2d.clear();
  h2d.clear();
  minv2d.clear();
  // the packed rows carry no rolling part: such scenes take the generic path
  if (dimension != 2 || rolling) return;
  for (int c = 0; c < size(); ++c) {
    PackedRow2d row;
    row.W = delassus[c].topLeftCorner<2, 2>();
    row.W_inverse = delassus_inverse[c].topLeftCorner<2, 2>();
    row.known = known[c].head<2>();
    row.bias = normal_bias[c];
    row.mu = friction[c];
    row.normal_inverse = normal_compliance_inverse[c];
    row.begin = static_cast<int>(h2d.size());
    for (int k = begin[c]; k < begin[c + 1]; ++k) h2d.push_back({h[k].x(), h[k].y(), dof[k]});
    row.end = static_cast<int>(h2d.size());
    row.minv_begin = static_cast<int>(minv2d.size());
    if (isDiagonal(c)) {
      for (int k = begin[c]; k < begin[c + 1]; ++k)
        minv2d.push_back({h_inverse_mass[k] * h[k].x(), h_inverse_mass[k] * h[k].y(), dof[k]});
    }
    for (int k = minv_begin[c]; k < minv_begin[c + 1]; ++k)
      minv2d.push_back({minv_h[k].x(), minv_h[k].y(), minv_dof[k]});
    row.minv_end = static_cast<int>(minv2d.size());
    rows2d.push_back(row);
  }
}

namespace {

bool sameBits(double a, double b) {
  return std::memcmp(&a, &b, sizeof(double)) == 0;
}

// Row c of p in body form (ContactProblem::PackedBodies3d), if its entries have that shape.
bool packBodies3d(const ContactProblem& p, int c, ContactProblem::PackedBodies3d& out) {
  const int first = p.begin[c], count = p.begin[c + 1] - first;
  if (!p.isDiagonal(c) || (count != 6 && count != 12)) return false;
  for (int block = 0; block < count / 6; ++block) {
    const int k0 = first + 6 * block;
    for (int i = 0; i < 6; ++i)
      if (p.dof[k0 + i] != p.dof[k0] + i) return false;
    for (int i = 0; i < 3; ++i) {
      if (p.rolling && !(p.rolling_h[k0 + i].x() == 0.0 && p.rolling_h[k0 + i].y() == 0.0))
        return false;
      if (!sameBits(p.h_inverse_mass[k0 + i], p.h_inverse_mass[k0])) return false;
      // equal as values: a zero coefficient may be +0 in both blocks, and it then adds a
      // signed zero where the entries add the other one, to a sum that cannot change
      if (block == 1 && p.h[k0 + i] != -p.h[first + i]) return false;
    }
  }
  auto rotation = [&](int k0, double(&normal)[3], double(&rest)[4][3], double(&inertia)[3]) {
    for (int i = 0; i < 3; ++i) {
      const int k = k0 + 3 + i;
      normal[i] = p.h[k].x();
      rest[0][i] = p.h[k].y();
      rest[1][i] = p.h[k].z();
      rest[2][i] = p.rolling ? p.rolling_h[k].x() : 0.0;
      rest[3][i] = p.rolling ? p.rolling_h[k].y() : 0.0;
      inertia[i] = p.h_inverse_mass[k];
    }
  };
  out = ContactProblem::PackedBodies3d{};
  for (int i = 0; i < 3; ++i) {
    out.translation_normal[i] = p.h[first + i].x();
    out.translation[0][i] = p.h[first + i].y();
    out.translation[1][i] = p.h[first + i].z();
  }
  out.dof_a = p.dof[first];
  out.inverse_mass_a = p.h_inverse_mass[first];
  rotation(first, out.rotation_normal_a, out.rotation_a, out.inverse_inertia_a);
  if (count == 12) {
    out.dof_b = p.dof[first + 6];
    out.inverse_mass_b = p.h_inverse_mass[first + 6];
    rotation(first + 6, out.rotation_normal_b, out.rotation_b, out.inverse_inertia_b);
  }
  return true;
}

}  // namespace

void ContactProblem::pack3d() {
  rows3d.clear();
  h3d.clear();
  minv3d.clear();
  packed_slot.clear();
  bodies3d.resize(direct_body_forms);  // the assembly's own records stay
  if (dimension != 3) return;
  for (int c = 0; c < size(); ++c) {
    if (sphereForm(c) >= 0) {  // the assembly's record is the packed row
      packed_slot.push_back(-1 - sphereForm(c));
      continue;
    }
    packed_slot.push_back(static_cast<int>(rows3d.size()));
    PackedRow3d row;
    row.W = delassus[c];
    row.W_inverse = delassus_inverse[c];
    row.known = known[c];
    row.bias = normal_bias[c];
    row.mu = friction[c];
    const bool diagonal_row = isDiagonal(c);
    row.begin = static_cast<int>(h3d.size());
    PackedBodies3d bodies;
    const bool body_form_row =
        bodyForm(c) >= 0 || (pack_body_form && packBodies3d(*this, c, bodies));
    if (bodyForm(c) >= 0) {
      row.body_form = bodyForm(c);
    } else if (body_form_row) {
      row.body_form = static_cast<int>(bodies3d.size());
      bodies3d.push_back(bodies);
    }
    for (int k = begin[c]; k < (body_form_row ? begin[c] : begin[c + 1]); ++k) {
      PackedEntry3d entry{
          h[k].x(), h[k].y(), h[k].z(), 0.0, 0.0, diagonal_row ? h_inverse_mass[k] : 0.0, dof[k]};
      if (rolling) {
        entry.rolling1 = rolling_h[k].x();
        entry.rolling2 = rolling_h[k].y();
      }
      h3d.push_back(entry);
    }
    row.end = static_cast<int>(h3d.size());
    row.minv_begin = static_cast<int>(minv3d.size());
    for (int k = minv_begin[c]; k < minv_begin[c + 1]; ++k) {  // none in a diagonal row
      PackedEntry3d entry{minv_h[k].x(), minv_h[k].y(), minv_h[k].z(), 0.0, 0.0, 0.0, minv_dof[k]};
      if (rolling) {
        entry.rolling1 = rolling_minv_h[k].x();
        entry.rolling2 = rolling_minv_h[k].y();
      }
      minv3d.push_back(entry);
    }
    row.minv_end = static_cast<int>(minv3d.size());
    if (rolling && rolling_bound[c] > 0.0) {
      row.rolling_bound = rolling_bound[c];
      row.rolling_W = rolling_delassus[c];
      row.rolling_known = rolling_known[c];
      const Matrix2& W_r = row.rolling_W;
      const double trace = W_r.trace();
      if (std::abs(W_r(0, 1)) <= 1e-12 * trace && std::abs(W_r(0, 0) - W_r(1, 1)) <= 1e-12 * trace)
        row.rolling_isotropic_inverse = 1.0 / W_r(0, 0);
      // H_r^T M^-1 H_c: how the contact's own impulse turns the rolling velocity
      if (diagonal_row) {
        forEachDiagonalEntry(c,
                             [&](int, const Vector3& h_k, const Vector2& h_r, double inverse_mass) {
                               row.rolling_coupling += h_r * (inverse_mass * h_k).transpose();
                             });
      } else {
        for (int m = minv_begin[c]; m < minv_begin[c + 1]; ++m) {
          if (minv_dof[m] >= static_cast<int>(pack_minv_slot.size()))
            pack_minv_slot.resize(minv_dof[m] + 1, -1);
          pack_minv_slot[minv_dof[m]] = m;
        }
        for (int k = begin[c]; k < begin[c + 1]; ++k) {
          const int m =
              dof[k] < static_cast<int>(pack_minv_slot.size()) ? pack_minv_slot[dof[k]] : -1;
          if (m >= 0) row.rolling_coupling += rolling_h[k] * minv_h[m].transpose();
        }
        for (int m = minv_begin[c]; m < minv_begin[c + 1]; ++m) pack_minv_slot[minv_dof[m]] = -1;
      }
    }
    rows3d.push_back(row);
  }
}

// A sphere particle also has one inverse inertia about every axis and only spheres centred
// on its origin (PackedSphere3d).
void findFreeParticles(const Model& model, const Data& data, const ContactModel& cmodel,
                       ContactProblemWorkspace& ws) {
  if (ws.free_particle.size() == model.bodies.size()) return;
  ws.free_particle.assign(model.bodies.size(), 0);
  ws.sphere_particles.assign(model.bodies.size(), {});
  std::vector<char> only_centred_spheres(model.bodies.size(), 1);
  std::vector<char> has_shape(model.bodies.size(), 0);
  for (const Geometry& g : cmodel.geometries) {
    if (g.body.kind != BodyRef::Kind::Dynamic) continue;
    has_shape[g.body.index] = 1;
    if (g.shape.type != ShapeType::Sphere || !g.placement.translation.isZero(0.0))
      only_centred_spheres[g.body.index] = 0;
  }
  for (std::size_t b = 0; b < model.bodies.size(); ++b) {
    const Body& body = model.bodies[b];
    if (body.parent >= 0 || body.joint.type != JointType::Floating) continue;
    // the Jacobian's linear columns are the joint frame's axes: the world's, exactly
    if (body.joint_placement.rotation != Matrix3::Identity()) continue;
    const double* inverse = data.constant_inverse_diagonal.data() + body.v_index;
    bool particle = true;
    for (int i = 0; i < 6; ++i) particle = particle && inverse[i] > 0.0;
    for (int i = 1; i < 3; ++i) particle = particle && sameBits(inverse[i], inverse[0]);
    ws.free_particle[b] = particle ? 1 : 0;
    const bool isotropic = sameBits(inverse[4], inverse[3]) && sameBits(inverse[5], inverse[3]);
    if (particle && isotropic && has_shape[b] && only_centred_spheres[b])
      ws.sphere_particles[b] = {body.v_index, body.component, inverse[0], inverse[3]};
  }
}

bool rowInBodyForm(const Model& model, const Data& data, const ContactModel& cmodel,
                   const Contact& contact, ContactProblemWorkspace& workspace) {
  if (cmodel.dimension != 3) return false;
  findFreeParticles(model, data, cmodel, workspace);
  bool moving = false;
  for (const BodyRef& body : {contact.body_a, contact.body_b}) {
    if (body.kind != BodyRef::Kind::Dynamic) continue;
    if (!workspace.free_particle[body.index]) return false;
    moving = true;
  }
  return moving;
}

namespace {
// Whether a row in body form may take the compact sphere form: every moving side a sphere
// particle (call after rowInBodyForm returned true for the contact).
bool sphereRowFits(const Contact& contact, const ContactProblemWorkspace& workspace) {
  for (const BodyRef& body : {contact.body_a, contact.body_b})
    if (body.kind == BodyRef::Kind::Dynamic && workspace.sphere_particles[body.index].v_index < 0)
      return false;
  return true;
}
}  // namespace

double touchingGap(const ContactModel& cmodel) {
  return 1e-9 * cmodel.margin_floor;
}

double normalBias(NormalLaw law, double restitution, double u_start, double gap, double tau) {
  double bias = restitution * u_start;
  if (law == NormalLaw::Iqs) bias += std::max(gap, 0.0) / tau;
  if (law == NormalLaw::Pos) bias += gap / tau;
  return bias;
}

void assembleContactProblem(const Model& model, const Data& data, const ContactModel& cmodel,
                            const ContactData& cdata, double t, NormalLaw law, double tau,
                            const VectorX& q_m, const VectorX& v_start, ContactProblem& p,
                            ContactProblemWorkspace& ws, const VectorX* v_free,
                            const std::vector<char>* deferred, int threads) {
  const ContactJacobian& J = cdata.jacobian;
  p.dimension = cmodel.dimension;
  p.rolling = J.rolling;
  p.bilateral.clear();
  const int rhs_columns = p.rolling ? 5 : 3;
  if (p.dimension == 3) findFreeParticles(model, data, cmodel, ws);  // before threads read it

  // Per-row and per-entry arrays are sized once the rows are counted, and every element is
  // then written (rows on several threads, each at its own place): nothing is cleared.
  auto sizeRows = [&](int rows) {
    p.contact.resize(rows);
    p.begin.resize(rows + 1);
    p.minv_begin.resize(rows + 1);
    p.begin[0] = p.minv_begin[0] = 0;
    p.diagonal.resize(rows);
    p.row_body_form.resize(rows);
    p.row_sphere.resize(rows);
    p.delassus.resize(rows);
    p.delassus_inverse.resize(rows);
    p.normal_compliance_inverse.resize(rows);
    p.known.resize(rows);
    p.gap.resize(rows);
    p.friction.resize(rows);
    p.restitution.resize(rows);
    p.velocity_start.resize(rows);
    p.normal_bias.resize(rows);
    p.row_components.resize(rows);
    ws.row_component.resize(rows);
    const int rolling_rows = p.rolling ? rows : 0;
    p.rolling_known.resize(rolling_rows);
    p.rolling_delassus.resize(rolling_rows);
    p.rolling_bound.resize(rolling_rows);
  };
  auto sizeEntries = [&](int entries, int minv_entries) {
    p.dof.resize(entries);
    p.h.resize(entries);
    p.h_inverse_mass.resize(entries);
    p.rolling_h.resize(p.rolling ? entries : 0);
    p.minv_dof.resize(minv_entries);
    p.minv_h.resize(minv_entries);
    p.rolling_minv_h.resize(p.rolling ? minv_entries : 0);
  };
  // islands: union-find over the components, a row's components joined
  for (std::size_t i = 0; i < ws.component_parent.size(); ++i)
    ws.component_parent[i] = static_cast<int>(i);
  auto root = [&](int c) {
    while (ws.component_parent[c] != c)
      c = ws.component_parent[c] = ws.component_parent[ws.component_parent[c]];
    return c;
  };
  auto join = [&](int first, int second) {
    const int a = root(first), b = root(second);
    if (a != b) ws.component_parent[std::max(a, b)] = std::min(a, b);
  };
  auto joinComponents = [&](const std::vector<int>& touched) {
    for (int comp : touched) join(touched.front(), comp);
  };
  // The components that entries [first, first + count) of dofs move, in order of first
  // appearance, into touched; returns whether every entry's dof has a diagonal constant
  // inverse mass (> 0 exactly there), the case where M^-1 H is H scaled.
  auto entryComponents = [&](const int* dofs, int count, std::vector<int>& touched) {
    touched.clear();
    bool diagonal_row = true;
    for (int k = 0; k < count; ++k) {
      diagonal_row = diagonal_row && data.constant_inverse_diagonal[dofs[k]] > 0.0;
      const int comp = ws.dof_component[dofs[k]];
      if (std::find(touched.begin(), touched.end(), comp) == touched.end()) touched.push_back(comp);
    }
    return diagonal_row;
  };
  // how many M^-1 H entries a general row over these components stores
  auto minvEntries = [&](const std::vector<int>& touched) {
    int count = 0;
    for (int comp : touched)
      count += data.has_constant_inverse6[comp] ? 6 : model.components[comp].nv;
    return count;
  };

  // one row block: H entries already pushed; computes M^-1 H, W_cc, velocities and bias
  // W_cc = H^T M^-1 H and W_r of a diagonal row (M^-1 H is H scaled), summed over its
  // entries in order, stored or in body form alike. Plain arrays: Eigen's outer products went
  // through the stack, and the stores stalled the loads of the next entry (the same products
  // in the same order, so the same bits).
  auto diagonalDelassus = [&](int pc, Matrix3& W, Matrix2& W_r) {
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
  };

  // the rest of row pc once its W_cc and W_r are known: its components, inverse, velocities
  // and bias (touched holds the components of the row; islands are joined afterwards)
  // diagonal_W: W is diagonal by construction (PackedSphere3d), and so is its inverse
  auto finishRowTail = [&](int pc, const std::vector<int>& touched, Matrix3 W, Matrix2 W_r,
                           const Vector3& known, double gap, double mu, double e,
                           const Vector2& known_spin, double rolling_bound,
                           bool diagonal_W = false) {
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
    if (p.rolling) {
      if (p.dimension == 2) W_r(1, 1) = W_r(0, 0);  // keeps the unused axis inert, not singular
      // a pair whose bodies cannot turn (no rotational inertia reached) has no rolling row
      if (!(W_r(0, 0) > 0.0 && W_r(1, 1) > 0.0)) rolling_bound = 0.0;
      p.rolling_delassus[pc] = W_r;
      p.rolling_known[pc] = known_spin;
      p.rolling_bound[pc] = rolling_bound;
    }
  };

  // Row pc from its H entries (written at [begin[pc], begin[pc + 1])): M^-1 H at
  // [minv_begin[pc], minv_begin[pc + 1]) unless the row is diagonal, W_cc, then the rest.
  // A general row uses the per-component and per-dof scratch of ws: one thread only.
  auto finishEntryRow = [&](int pc, const std::vector<int>& touched, bool diagonal_row,
                            const Vector3& known, double gap, double mu, double e,
                            const Vector2& known_spin, double rolling_bound) {
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
        MatrixX& solved = ws.component_rhs[comp];
        solved.setZero(component.nv, rhs_columns);
        for (int k = p.begin[pc]; k < p.begin[pc + 1]; ++k) {
          if (ws.dof_component[p.dof[k]] != comp) continue;
          const int i = p.dof[k] - component.v_index;
          solved.row(i).head<3>() = p.h[k].transpose();
          if (p.rolling) solved.row(i).tail<2>() = p.rolling_h[k].transpose();
        }
        data.mass_factors[comp].solveInPlace(solved);
        for (int i = 0; i < component.nv; ++i, ++slot) {
          p.minv_dof[slot] = component.v_index + i;
          p.minv_h[slot] = Vector3(solved(i, 0), solved(i, 1), solved(i, 2));
          if (p.rolling) p.rolling_minv_h[slot] = Vector2(solved(i, 3), solved(i, 4));
        }
      }
      // W_cc = H_c^T M^-1 H_c
      for (int m = p.minv_begin[pc]; m < p.minv_begin[pc + 1]; ++m) ws.minv_slot[p.minv_dof[m]] = m;
      for (int k = p.begin[pc]; k < p.begin[pc + 1]; ++k) {
        const int m = ws.minv_slot[p.dof[k]];
        if (m < 0) continue;
        W += p.h[k] * p.minv_h[m].transpose();
        if (p.rolling) W_r += p.rolling_h[k] * p.rolling_minv_h[m].transpose();
      }
      for (int m = p.minv_begin[pc]; m < p.minv_begin[pc + 1]; ++m)
        ws.minv_slot[p.minv_dof[m]] = -1;
    }
    finishRowTail(pc, touched, W, W_r, known, gap, mu, e, known_spin, rolling_bound);
  };

  // The two sides of a contact written from its frame and points: a driven side adds its
  // motion at t to known and spin; visit(body, point, sign) for each dynamic side, with sign
  // -1 on side a and +1 on side b
  auto forEachSide = [&](const Contact& contact, Vector3& known, Vector2& spin, auto&& visit) {
    for (int side = 0; side < 2; ++side) {
      const BodyRef& ref = side == 0 ? contact.body_a : contact.body_b;
      const Vector3& point = side == 0 ? contact.point_a : contact.point_b;
      const double sign = side == 0 ? -1.0 : 1.0;
      if (ref.kind == BodyRef::Kind::Driven)
        addDrivenVelocity(model.driven_bodies[ref.index], contact, point, contact.tangent1,
                          contact.tangent2, sign, t, known, spin);
      else if (ref.kind == BodyRef::Kind::Dynamic)
        visit(ref.index, point, sign);
    }
  };

  // A row over free particles, written straight in body form from the contact's frame and
  // points (rowInBodyForm): the Jacobian's columns of a free body with the arithmetic of
  // assembleContactJacobian, W_cc and W_r over the entries the record stands for in their
  // order, so the row has the bits of one assembled from entries and packed by pack3d. On a
  // powder bed this skips three copies of every row (Jacobian, H entries, packing).
  auto bodyFormRow = [&](int pc, const Contact& contact, std::vector<int>& touched) {
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
  };

  // A row over spheres in compact form (ContactProblem::PackedSphere3d): the frame, each
  // side's signed lever along the normal and its axes R^T t1, R^T t2, written in place.
  auto sphereRow = [&](int pc, const Contact& contact, std::vector<int>& touched) {
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
  };

  // A contact's row from its Jacobian entries
  auto contactEntryRow = [&](int pc, int c, std::vector<int>& touched) {
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
                   contact.rolling);
  };

  // The contacts' rows in three passes: what row each contact makes (threads), the rows
  // numbered in contact order with their places in the arrays, then the rows written, each
  // at its place (threads; general rows, which share scratch, on one thread). Each row's
  // arithmetic is the same on any thread: the problem has the same bits for every count.
  enum RowKind : char { kNoRow, kSphereRow, kBodyFormRow, kDiagonalRow, kSerialRow };
  const double touching = touchingGap(cmodel);
  const bool body_form = p.pack_body_form && p.dimension == 3;
  const bool compact_spheres = body_form && p.compact_spheres;
  const int m = static_cast<int>(cdata.contacts.size());
  if (m < kParallelItems) threads = 1;
  threads = std::max(threads, 1);
  if (static_cast<int>(ws.thread_touched.size()) < threads) ws.thread_touched.resize(threads);
  ws.row_kind.resize(m);
  ws.row_minv_entries.resize(m);
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1)
  for (int c = 0; c < m; ++c) {
    const Contact& contact = cdata.contacts[c];
    char kind = kNoRow;
    int minv_entries = 0;
    // index set: VEL takes closed contacts only; the gap-aware laws take every candidate
    if ((law == NormalLaw::Vel && contact.gap > touching) ||
        (deferred != nullptr && (*deferred)[c])) {
    } else if (body_form && rowInBodyForm(model, data, cmodel, contact, ws)) {
      kind = compact_spheres && sphereRowFits(contact, ws) ? kSphereRow : kBodyFormRow;
    } else {
      std::vector<int>& touched = ws.thread_touched[omp_get_thread_num()];
      const bool diagonal_row =
          entryComponents(&J.dof[J.begin[c]], J.begin[c + 1] - J.begin[c], touched);
      kind = diagonal_row && touched.size() <= 2 ? kDiagonalRow : kSerialRow;
      if (!diagonal_row) minv_entries = minvEntries(touched);
    }
    ws.row_kind[c] = kind;
    ws.row_minv_entries[c] = minv_entries;
  }
  int rows = 0, entries = 0, minv_entries = 0, spheres = 0, body_forms = 0;
  for (int c = 0; c < m; ++c) rows += ws.row_kind[c] != kNoRow;
  sizeRows(rows);
  for (int c = 0, pc = 0; c < m; ++c) {
    const char kind = ws.row_kind[c];
    if (kind == kNoRow) continue;
    p.contact[pc] = c;
    p.row_sphere[pc] = kind == kSphereRow ? spheres++ : -1;
    p.row_body_form[pc] = kind == kBodyFormRow ? body_forms++ : -1;
    if (kind == kDiagonalRow || kind == kSerialRow) entries += J.begin[c + 1] - J.begin[c];
    minv_entries += ws.row_minv_entries[c];
    ++pc;
    p.begin[pc] = entries;
    p.minv_begin[pc] = minv_entries;
  }
  sizeEntries(entries, minv_entries);
  p.spheres3d.resize(spheres);
  p.bodies3d.resize(body_forms);
  p.direct_body_forms = body_forms;
#pragma omp parallel for schedule(static) num_threads(threads) if (threads > 1)
  for (int pc = 0; pc < rows; ++pc) {
    const int c = p.contact[pc];
    std::vector<int>& touched = ws.thread_touched[omp_get_thread_num()];
    switch (ws.row_kind[c]) {
      case kSphereRow:
        sphereRow(pc, cdata.contacts[c], touched);
        break;
      case kBodyFormRow:
        bodyFormRow(pc, cdata.contacts[c], touched);
        break;
      case kDiagonalRow:
        contactEntryRow(pc, c, touched);
        break;
      default:
        break;
    }
  }
  for (int pc = 0; pc < rows; ++pc) {
    if (ws.row_kind[p.contact[pc]] != kSerialRow) continue;
    contactEntryRow(pc, p.contact[pc], ws.touched);
    joinComponents(ws.touched);
  }

  // a row appended after the contacts' rows, on one thread: entries(first) writes its H
  // entries at [first, first + count)
  auto appendEntryRow = [&](int id, int count, auto&& writeEntries, const Vector3& known,
                            double gap, double mu, double e) {
    const int pc = p.size();
    sizeRows(pc + 1);
    p.contact[pc] = id;
    const int first = static_cast<int>(p.dof.size());
    p.begin[pc + 1] = first + count;
    sizeEntries(first + count, static_cast<int>(p.minv_dof.size()));
    writeEntries(first);
    const bool diagonal_row = entryComponents(&p.dof[first], count, ws.touched);
    const int minv_first = static_cast<int>(p.minv_dof.size());
    p.minv_begin[pc + 1] = minv_first + (diagonal_row ? 0 : minvEntries(ws.touched));
    sizeEntries(first + count, p.minv_begin[pc + 1]);
    finishEntryRow(pc, ws.touched, diagonal_row, known, gap, mu, e, Vector2::Zero(), 0.0);
    joinComponents(ws.touched);
  };

  // Under VEL a limit or a constraint by functions is closed at gap <= kClosedGap (m or rad):
  // a state placed on the constraint lands a few ulps off it, and must not start open.
  constexpr double kClosedGap = 1e-12;
  // joint limits: gap = side (q - bound) >= 0, W_N = side on the joint's velocity
  for (int l = 0; l < static_cast<int>(model.limits.size()); ++l) {
    const JointLimit& limit = model.limits[l];
    const double gap = limit.side * (q_m[limit.q_index] - limit.bound);
    double rate = std::abs(v_start[limit.v_index]);
    if (v_free) rate = std::max(rate, std::abs((*v_free)[limit.v_index]));
    const double reach = law == NormalLaw::Vel ? kClosedGap : 2.0 * tau * rate;
    if (gap > reach) continue;
    appendEntryRow(
        -1 - l, 1,
        [&](int first) {
          p.dof[first] = limit.v_index;
          p.h[first] = Vector3(limit.side, 0.0, 0.0);
          if (p.rolling) p.rolling_h[first] = Vector2::Zero();
        },
        Vector3::Zero(), gap, 0.0, 0.0);
  }

  // constraints by functions (Model::constraints): gap, normal and tangents at q_m
  const int limit_count = static_cast<int>(model.limits.size());
  for (int k = 0; k < static_cast<int>(model.constraints.size()); ++k) {
    const ConstraintFunction& f = model.constraints[k];
    const double gap = f.gap(q_m);
    const auto direction = [&](const std::function<VectorX(const VectorX&)>& of, const char* what) {
      VectorX w = of ? of(q_m) : VectorX::Zero(model.nv);
      if (w.size() != model.nv || !w.allFinite() || !std::isfinite(gap))
        throw std::runtime_error("constraint '" + f.name + "': its " + what +
                                 " must be finite with nv = " + std::to_string(model.nv) +
                                 " entries (and its gap finite)");
      return w;
    };
    const VectorX normal = direction(f.normal, "normal");
    double rate = std::abs(normal.dot(v_start));
    if (v_free) rate = std::max(rate, std::abs(normal.dot(*v_free)));
    const double reach = law == NormalLaw::Vel ? kClosedGap : 2.0 * tau * rate;
    if (gap > reach && !f.bilateral) continue;
    if (normal.isZero(0.0))
      throw std::runtime_error("constraint '" + f.name + "': its normal is zero at the gap " +
                               std::to_string(gap) + ": the constraint moves nothing");
    const VectorX tangent = direction(f.tangent, "tangent");
    const VectorX tangent2 =
        p.dimension == 3 ? direction(f.tangent2, "second tangent") : VectorX::Zero(model.nv);
    auto nonzero = [&](int j) {
      return normal[j] != 0.0 || tangent[j] != 0.0 || tangent2[j] != 0.0;
    };
    int count = 0;
    for (int j = 0; j < model.nv; ++j) count += nonzero(j);
    appendEntryRow(
        -1 - (limit_count + k), count,
        [&](int first) {
          for (int j = 0; j < model.nv; ++j) {
            if (!nonzero(j)) continue;
            p.dof[first] = j;
            p.h[first] = Vector3(normal[j], tangent[j], tangent2[j]);
            if (p.rolling) p.rolling_h[first] = Vector2::Zero();
            ++first;
          }
        },
        Vector3::Zero(), gap, f.friction, f.restitution);
    if (f.bilateral) {
      p.bilateral.resize(p.size(), 0);
      p.bilateral.back() = 1;
    }
  }
  if (!p.bilateral.empty()) p.bilateral.resize(p.size(), 0);

  // the rows of two components or fewer, joined here (the others were, as they were made)
  const int n = p.size();
  for (int c = 0; c < n; ++c) {
    const std::array<int, 2>& moved = p.row_components[c];
    if (moved[0] >= 0 && moved[1] >= 0) join(moved[0], moved[1]);
  }

  // islands numbered in order of their first row: deterministic
  std::fill(ws.island_of_root.begin(), ws.island_of_root.end(), -1);
  std::vector<int>& island_begin = p.island_begin;
  island_begin.assign(1, 0);
  int islands = 0;
  for (int c = 0; c < n; ++c) {
    int& id = ws.island_of_root[root(ws.row_component[c])];
    if (id < 0) {
      id = islands++;
      island_begin.push_back(0);
    }
    ++island_begin[id + 1];
  }
  for (int i = 0; i < islands; ++i) island_begin[i + 1] += island_begin[i];
  p.island_rows.resize(n);
  ws.touched.assign(island_begin.begin(), island_begin.end() - 1);  // fill cursors
  for (int c = 0; c < n; ++c)
    p.island_rows[ws.touched[ws.island_of_root[root(ws.row_component[c])]]++] = c;
  // packed rows have no bilateral case: such problems take the generic paths
  if (p.pack_rows && p.bilateral.empty()) {
    p.pack2d();
    p.pack3d();
  } else {
    p.rows2d.clear();
    p.packed_slot.clear();
  }
}

}  // namespace sweep
