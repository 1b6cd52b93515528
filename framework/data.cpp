#include "framework/data.hpp"

#include "framework/crba.hpp"

namespace sweep {

Data::Data(const Model& model)
    : parent_pose(model.bodies.size()),
      world_pose(model.bodies.size()),
      motion_subspace(model.bodies.size()),
      bias_acceleration(model.bodies.size(), Vector6::Zero()),
      velocity(model.bodies.size(), Vector6::Zero()),
      acceleration(model.bodies.size(), Vector6::Zero()),
      force(model.bodies.size(), Vector6::Zero()),
      composite_inertia(model.bodies.size()),
      mass_factors(model.components.size()),
      tau(VectorX::Zero(model.nv)),
      ddq(VectorX::Zero(model.nv)) {
  mass_blocks.reserve(model.components.size());
  for (const Component& c : model.components) mass_blocks.emplace_back(MatrixX::Zero(c.nv, c.nv));
  // constant blocks do not depend on q: any configuration will do, so take the neutral one
  computeMassBlocks(model, *this, model.neutralConfiguration(), /*include_constant=*/true);
  constant_inverse6.assign(model.components.size(), Matrix6::Zero());
  has_constant_inverse6.assign(model.components.size(), 0);
  constant_inverse6_diagonal.assign(model.components.size(), 0);
  constant_inverse_diagonal = VectorX::Zero(model.nv);
  constant_small_diagonal.assign(model.components.size(), 0);
  small_inverse_diagonal = VectorX::Zero(model.nv);
  for (size_t c = 0; c < model.components.size(); ++c) {
    if (!model.components[c].constant_mass) continue;
    mass_factors[c].compute(mass_blocks[c]);
    if (model.components[c].nv == 6 && mass_factors[c].info() == Eigen::Success) {
      constant_inverse6[c] = mass_factors[c].solve(MatrixX::Identity(6, 6));
      has_constant_inverse6[c] = 1;
      const Matrix6& inverse = constant_inverse6[c];
      constant_inverse6_diagonal[c] = Matrix6(inverse.diagonal().asDiagonal()) == inverse;
      if (constant_inverse6_diagonal[c])
        constant_inverse_diagonal.segment<6>(model.components[c].v_index) = inverse.diagonal();
    } else if (model.components[c].nv < 6 && mass_factors[c].info() == Eigen::Success) {
      const MatrixX& block = mass_blocks[c];
      if (MatrixX(block.diagonal().asDiagonal()) == block &&
          (block.diagonal().array() > 0.0).all()) {
        constant_small_diagonal[c] = 1;
        small_inverse_diagonal.segment(model.components[c].v_index, model.components[c].nv) =
            block.diagonal().cwiseInverse();
      }
    }
  }
}

}  // namespace sweep
