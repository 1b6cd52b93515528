#pragma once
// The mutable workspace of the algorithms, sized once from a Model: Data data(model).
#include <Eigen/Cholesky>
#include <vector>

#include "framework/model.hpp"

namespace sweep {

struct Data {
  explicit Data(const Model& model);

  // per body (model order)
  std::vector<Pose> parent_pose;                // body frame in the parent body frame (or world)
  std::vector<Pose> world_pose;                 // body frame in world
  std::vector<MotionSubspace> motion_subspace;  // S, body coordinates
  std::vector<Vector6> bias_acceleration;       // c_J = Sdot v, body coordinates
  std::vector<Vector6> velocity;                // spatial velocity, body coordinates
  std::vector<Vector6> acceleration;            // spatial acceleration, body coordinates
  std::vector<Vector6> force;                   // net force transmitted by the joint
  std::vector<Inertia> composite_inertia;       // CRBA composite body inertias

  // per component: M block, and its Cholesky factor (constant blocks are factored here, once)
  std::vector<MatrixX> mass_blocks;
  std::vector<Eigen::LLT<MatrixX>> mass_factors;
  // M + diag(added) of the components forwardDynamicsWithAddedMass shifts (empty otherwise)
  std::vector<MatrixX> shifted_mass;
  // constant 6 x 6 blocks (free rigid bodies: every grain) also as their inverse, so that the
  // contact assembly's M^-1 H is one fixed-size product instead of a dynamic-size triangular
  // solve per contact (docs/powder_bed.md); empty matrices elsewhere
  std::vector<Matrix6> constant_inverse6;
  std::vector<char> has_constant_inverse6;
  std::vector<char> constant_inverse6_diagonal;  // exactly: its off-diagonal entries are zero
  // per velocity: the diagonal of its component's constant inverse where that is diagonal,
  // 0 elsewhere. One contiguous read per body where the 6 x 6 blocks cost six cache lines.
  VectorX constant_inverse_diagonal;
  // per component with fewer than 6 velocities: whether its constant block is diagonal (a
  // planar body about its centre of mass), and per velocity that block's inverse diagonal,
  // so that the assembly scales H instead of a dynamic-size triangular solve per contact
  std::vector<char> constant_small_diagonal;
  VectorX small_inverse_diagonal;

  VectorX tau;  // generalized force out of rnea()
  VectorX ddq;  // generalized acceleration out of forwardDynamics()
  // models with systems by their equations: the state of the last forwardKinematics, which
  // their mass matrices and energies read (empty otherwise)
  VectorX q, v;
  // the passes over the body trees (kinematics, RNEA, mass blocks, M^-1) run on this many
  // threads when the model has kParallelItems trees or more (framework/parallel.hpp)
  int threads = 1;
  // the body trees those passes visit: every one, or with restrict_components only those in
  // `components`; the others' entries are left as they were. A rank of a distributed run steps
  // its own and its ghost grains only (integrators/distributed_stepper.hpp).
  bool restrict_components = false;
  std::vector<int> components;
  const std::vector<int>* componentSubset() const {
    return restrict_components ? &components : nullptr;
  }
};

}  // namespace sweep
