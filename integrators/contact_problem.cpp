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

ContactProblemWorkspace::ContactProblemWorkspace(const Model& model)
    : component_rhs(model.components.size()),
      dof_component(model.nv, 0),
      component_parent(model.components.size()),
      island_of_root(model.components.size()),
      entry_scratch(1) {
  entry_scratch[0].minv_slot.assign(model.nv, -1);
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

double touchingGap(const ContactModel& cmodel) {
  return 1e-9 * cmodel.margin_floor;
}

double heldGap(const ContactModel& cmodel) {
  return 1e-6 * cmodel.margin_floor;
}

bool closedForVel(const ContactModel& cmodel, const ContactData& cdata, int id) {
  const bool held = id < static_cast<int>(cdata.held.size()) && cdata.held[id];
  const Contact& c = cdata.contacts[id];
  if (c.gap <= (held ? heldGap(cmodel) : touchingGap(cmodel))) return true;
  // an adhesive contact within its range pulls before it touches: a row, with IQS's gap term
  return cmodel.adhesive() && adhesionForce(cmodel, c) > 0.0;
}

double adhesionForce(const ContactModel& cmodel, const Contact& c) {
  const ContactModel::Traits& a = cmodel.traits[c.key.geometry_a];
  const ContactModel::Traits& b = cmodel.traits[c.key.geometry_b];
  const ContactLaw& law = cmodel.materials.law(a.material, b.material);
  if (!law.adhesive() || c.gap > std::max(law.adhesion_range, heldGap(cmodel))) return 0.0;
  return pullOffForce(law, a.ball_radius, b.ball_radius);
}

double normalBias(NormalLaw law, double restitution, double u_start, double gap, double tau) {
  double bias = restitution * u_start;
  if (law == NormalLaw::Iqs) bias += std::max(gap, 0.0) / tau;
  if (law == NormalLaw::Pos) bias += gap / tau;
  return bias;
}

}  // namespace sweep
