#include "framework/crba.hpp"

#include "framework/kinematics.hpp"
#include "framework/parallel.hpp"

#include <stdexcept>
#include <string>

namespace sweep {

MatrixX systemMass(const Model& model, int component, const VectorX& q) {
  const Component& comp = model.components[component];
  const EquationSystem& system = model.systems[comp.system];
  MatrixX M = system.mass(q.segment(comp.q_index, comp.nq));
  if (M.rows() != comp.nv || M.cols() != comp.nv || !M.allFinite())
    throw std::runtime_error("system '" + system.name + "': its mass matrix must be a finite " +
                             std::to_string(comp.nv) + " x " + std::to_string(comp.nv) +
                             " matrix, got " + std::to_string(M.rows()) + " x " +
                             std::to_string(M.cols()));
  return M;
}

void computeMassBlocks(const Model& model, Data& data, bool include_constant) {
  // systems by their equations on this thread (their mass may call back into Python)
  for (size_t c = 0; c < model.components.size(); ++c) {
    const Component& comp = model.components[c];
    if (comp.system >= 0 && (include_constant || !comp.constant_mass))
      data.mass_blocks[c] = systemMass(model, c, data.q);
  }
  forEachBodyComponent(model, data.componentSubset(), data.threads, [&](int c) {
    const Component& comp = model.components[c];
    if (comp.constant_mass && !include_constant) return;
    MatrixX& block = data.mass_blocks[c];

    // backward pass: composite inertias, each in its own body frame
    for (int i = comp.first_body; i < comp.end_body; ++i)
      data.composite_inertia[i] = model.bodies[i].inertia;
    for (int i = comp.end_body - 1; i > comp.first_body; --i) {
      const int parent = model.bodies[i].parent;
      data.composite_inertia[parent] += data.composite_inertia[i].expressedIn(data.parent_pose[i]);
    }

    // M_ij = S_j^T X_{j<-i}^* (I^c_i S_i) for every ancestor j of i
    for (int i = comp.first_body; i < comp.end_body; ++i) {
      const MotionSubspace& Si = data.motion_subspace[i];
      const int ni = static_cast<int>(Si.cols());
      if (ni == 0) continue;
      const int vi = model.bodies[i].v_index - comp.v_index;
      Matrix6 F;
      for (int k = 0; k < ni; ++k) F.col(k) = data.composite_inertia[i].apply(Si.col(k));
      for (int a = 0; a < ni; ++a)
        for (int k = 0; k < ni; ++k) block(vi + a, vi + k) = Si.col(a).dot(F.col(k));
      for (int j = i; model.bodies[j].parent >= 0;) {
        for (int k = 0; k < ni; ++k) F.col(k) = data.parent_pose[j].forceToParent(F.col(k));
        j = model.bodies[j].parent;
        const MotionSubspace& Sj = data.motion_subspace[j];
        const int nj = static_cast<int>(Sj.cols());
        if (nj == 0) continue;
        const int vj = model.bodies[j].v_index - comp.v_index;
        for (int a = 0; a < nj; ++a) {
          for (int k = 0; k < ni; ++k) {
            const double m = Sj.col(a).dot(F.col(k));
            block(vj + a, vi + k) = m;
            block(vi + k, vj + a) = m;
          }
        }
      }
    }
  });
}

void computeMassBlocks(const Model& model, Data& data, const VectorX& q, bool include_constant) {
  forwardKinematics(model, data, q);
  computeMassBlocks(model, data, include_constant);
}

void crba(const Model& model, Data& data, const VectorX& q) {
  computeMassBlocks(model, data, q, /*include_constant=*/false);
}

void factorizeMassMatrix(const Model& model, Data& data) {
  forEachBodyComponent(model, data.componentSubset(), data.threads, [&](int c) {
    if (!model.components[c].constant_mass) data.mass_factors[c].compute(data.mass_blocks[c]);
  });
  for (size_t c = model.components.size() - model.systems.size(); c < model.components.size(); ++c)
    if (!model.components[c].constant_mass) data.mass_factors[c].compute(data.mass_blocks[c]);
}

void applyMassInverse(const Model& model, const Data& data, const VectorX& rhs, VectorX& out) {
  if (&out != &rhs) out = rhs;
  auto solve = [&](int c) {
    const Component& comp = model.components[c];
    if (comp.nv == 0) return;
    if (data.has_constant_inverse6[c]) {
      // a free body's constant block: one 6x6 product instead of two triangular solves
      const Vector6 rhs_block = out.segment<6>(comp.v_index);
      if (data.constant_inverse6_diagonal[c])
        out.segment<6>(comp.v_index) = data.constant_inverse6[c].diagonal().cwiseProduct(rhs_block);
      else
        out.segment<6>(comp.v_index).noalias() = data.constant_inverse6[c] * rhs_block;
      return;
    }
    auto segment = out.segment(comp.v_index, comp.nv);
    data.mass_factors[c].solveInPlace(segment);
  };
  forEachBodyComponent(model, data.componentSubset(), data.threads, solve);
  for (int c = static_cast<int>(model.components.size() - model.systems.size());
       c < static_cast<int>(model.components.size()); ++c)
    solve(c);
}

void applyMass(const Model& model, const Data& data, const VectorX& rhs, VectorX& out) {
  out.resize(model.nv);
  for (size_t c = 0; c < model.components.size(); ++c) {
    const Component& comp = model.components[c];
    out.segment(comp.v_index, comp.nv).noalias() =
        data.mass_blocks[c] * rhs.segment(comp.v_index, comp.nv);
  }
}

MatrixX denseMassMatrix(const Model& model, const Data& data) {
  MatrixX m = MatrixX::Zero(model.nv, model.nv);
  for (size_t c = 0; c < model.components.size(); ++c) {
    const Component& comp = model.components[c];
    m.block(comp.v_index, comp.v_index, comp.nv, comp.nv) = data.mass_blocks[c];
  }
  return m;
}

}  // namespace sweep
