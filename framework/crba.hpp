#pragma once
// Joint-space mass matrix by the composite-rigid-body algorithm (Featherstone 2008, Table 6.2),
// stored as one dense block per component (M is block diagonal across independent trees).
#include "framework/data.hpp"

namespace sweep {

// Forward kinematics at q, then the mass blocks of every component whose mass depends on q.
// Constant blocks (free particles) were computed and factored when Data was built.
void crba(const Model& model, Data& data, const VectorX& q);

// Mass blocks from the current data.parent_pose / data.motion_subspace (forwardKinematics).
void computeMassBlocks(const Model& model, Data& data, bool include_constant);
// The mass matrix of a component that is a system by its equations, at q (the whole model's);
// runtime_error when its function returns a matrix of another size or not finite.
MatrixX systemMass(const Model& model, int component, const VectorX& q);
// Convenience: forward kinematics at q, then computeMassBlocks.
void computeMassBlocks(const Model& model, Data& data, const VectorX& q, bool include_constant);

// Cholesky factors of the configuration-dependent blocks (after crba).
void factorizeMassMatrix(const Model& model, Data& data);

// out = M^-1 rhs, block by block, using the factors (after factorizeMassMatrix).
void applyMassInverse(const Model& model, const Data& data, const VectorX& rhs, VectorX& out);

// out = M rhs, block by block.
void applyMass(const Model& model, const Data& data, const VectorX& rhs, VectorX& out);

// The full nv x nv matrix, for tests and small systems.
MatrixX denseMassMatrix(const Model& model, const Data& data);

}  // namespace sweep
