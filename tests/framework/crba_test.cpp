#include "framework/crba.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <random>

#include "framework/energy.hpp"
#include "framework/kinematics.hpp"
#include "framework/rnea.hpp"
#include "test_models.hpp"

namespace sweep {
namespace {

class CrbaTest : public test::ModelTest {};

TEST_P(CrbaTest, MassMatrixIsSymmetricPositiveDefinite) {
  const Model& model = *model_;
  Data data(model);
  std::mt19937 rng(3);
  for (int trial = 0; trial < 10; ++trial) {
    crba(model, data, test::randomConfiguration(model, rng));
    const MatrixX m = denseMassMatrix(model, data);
    EXPECT_LT((m - m.transpose()).norm(), 1e-14 * m.norm());
    EXPECT_GT(Eigen::SelfAdjointEigenSolver<MatrixX>(m).eigenvalues().minCoeff(), 0.0);
  }
}

TEST_P(CrbaTest, EqualsRneaColumnByColumn) {
  // M e_i = rnea(q, 0, e_i) - rnea(q, 0, 0): gravity cancels, velocity terms vanish
  const Model& model = *model_;
  Data data(model);
  std::mt19937 rng(5);
  const VectorX q = test::randomConfiguration(model, rng);
  crba(model, data, q);
  const MatrixX m = denseMassMatrix(model, data);
  const VectorX zero = VectorX::Zero(model.nv);
  const VectorX gravity = rnea(model, data, q, zero, zero);
  for (int i = 0; i < model.nv; ++i) {
    const VectorX column = rnea(model, data, q, zero, VectorX::Unit(model.nv, i)) - gravity;
    EXPECT_LT((column - m.col(i)).norm(), 1e-12 * std::max(1.0, m.norm())) << "column " << i;
  }
}

TEST_P(CrbaTest, KineticEnergyIsSumOverBodies) {
  const Model& model = *model_;
  Data data(model);
  std::mt19937 rng(9);
  const VectorX q = test::randomConfiguration(model, rng);
  const VectorX v = test::randomVector(model.nv, rng);
  crba(model, data, q);
  const double quadratic = 0.5 * v.dot(denseMassMatrix(model, data) * v);
  forwardKinematics(model, data, q, v);
  EXPECT_NEAR(kineticEnergy(model, data), quadratic, 1e-12 * std::max(1.0, quadratic));
}

TEST_P(CrbaTest, MassInverseAppliesInverse) {
  const Model& model = *model_;
  Data data(model);
  std::mt19937 rng(13);
  crba(model, data, test::randomConfiguration(model, rng));
  factorizeMassMatrix(model, data);
  const VectorX rhs = test::randomVector(model.nv, rng);
  VectorX x;
  applyMassInverse(model, data, rhs, x);
  VectorX back;
  applyMass(model, data, x, back);
  EXPECT_LT((back - rhs).norm(), 1e-10 * rhs.norm());
}

TEST(Crba, ConstantBlocksAreNeverRebuilt) {
  const Model model = test::mixedBodies();
  Data data(model);
  ASSERT_EQ(model.components.size(), 4u);
  EXPECT_TRUE(model.components[0].constant_mass);   // disk, frame at the centre
  EXPECT_TRUE(model.components[1].constant_mass);   // box, frame at the centre
  EXPECT_FALSE(model.components[2].constant_mass);  // sphere with an off-centre frame
  EXPECT_TRUE(model.components[3].constant_mass);   // one revolute joint
  // poison the constant blocks: crba must leave them alone, and rebuild the varying one
  const MatrixX disk = data.mass_blocks[0];
  data.mass_blocks[0].setConstant(42.0);
  data.mass_blocks[2].setConstant(42.0);
  std::mt19937 rng(1);
  crba(model, data, test::randomConfiguration(model, rng));
  EXPECT_EQ(data.mass_blocks[0](0, 0), 42.0);
  EXPECT_NE(data.mass_blocks[2](0, 0), 42.0);
  EXPECT_DOUBLE_EQ(disk(0, 0), 1.0);
  EXPECT_DOUBLE_EQ(disk(2, 2), 0.5 * 1.0 * 0.2 * 0.2);
  EXPECT_EQ(disk(0, 2), 0.0);
}

// The stored inverse of a constant 6 x 6 block (the box: a free rigid body) is its inverse;
// blocks of other sizes or varying ones carry none.
TEST(Crba, ConstantSixBySixBlocksCarryTheirInverse) {
  const Model model = test::mixedBodies();
  const Data data(model);
  int with_inverse = 0;
  for (std::size_t c = 0; c < model.components.size(); ++c) {
    const bool expected = model.components[c].constant_mass && model.components[c].nv == 6;
    EXPECT_EQ(data.has_constant_inverse6[c] != 0, expected) << c;
    if (!data.has_constant_inverse6[c]) continue;
    ++with_inverse;
    const MatrixX product = data.constant_inverse6[c] * data.mass_blocks[c];
    EXPECT_LT((product - MatrixX::Identity(6, 6)).norm(), 1e-12) << c;
  }
  EXPECT_EQ(with_inverse, 1);
}

// A free body on its principal axes has a diagonal inverse and is flagged so (rows are then
// scaled, not multiplied); one whose inertia is not on its axes is not. Both apply M^-1 as
// the factored block does.
TEST(Crba, DiagonalConstantInversesAreFlaggedAndApplied) {
  ModelBuilder b("free bodies");
  addFreeBody(b, "box", solidBoxInertia(2.0, Vector3(0.3, 0.2, 0.1)));
  Inertia tilted = solidBoxInertia(1.0, Vector3(0.4, 0.1, 0.2));
  const Matrix3 turn = Eigen::AngleAxisd(0.3, Vector3(1, 2, 3).normalized()).toRotationMatrix();
  tilted.inertia_com = turn * tilted.inertia_com * turn.transpose();
  addFreeBody(b, "tilted", tilted);
  const Model model = b.build();
  const Data data(model);
  ASSERT_EQ(data.has_constant_inverse6, (std::vector<char>{1, 1}));
  EXPECT_EQ(data.constant_inverse6_diagonal, (std::vector<char>{1, 0}));
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  VectorX rhs(model.nv);
  for (int i = 0; i < model.nv; ++i) rhs[i] = u(rng);
  VectorX x;
  applyMassInverse(model, data, rhs, x);
  for (std::size_t c = 0; c < model.components.size(); ++c) {
    const Component& component = model.components[c];
    const VectorX expected = data.mass_factors[c].solve(rhs.segment(component.v_index, 6));
    EXPECT_LT((x.segment(component.v_index, 6) - expected).norm(), 1e-12 * expected.norm()) << c;
  }
}

// The skip changes nothing: with every block forced to be rebuilt, CRBA gives the blocks
// the constant ones hold, at any configuration.
TEST(Crba, SkippingConstantBlocksGivesTheRebuiltMatrix) {
  const Model model = test::mixedBodies();
  Model rebuilt = model;
  for (Component& component : rebuilt.components) component.constant_mass = false;
  Data skipping(model), rebuilding(rebuilt);
  std::mt19937 rng(3);
  for (int trial = 0; trial < 5; ++trial) {
    const VectorX q = test::randomConfiguration(model, rng);
    crba(model, skipping, q);
    crba(rebuilt, rebuilding, q);
    const MatrixX a = denseMassMatrix(model, skipping);
    const MatrixX b = denseMassMatrix(rebuilt, rebuilding);
    EXPECT_LT((a - b).norm(), 1e-12 * b.norm());
  }
}

TEST(Crba, IndependentBodiesGiveBlockDiagonalMatrix) {
  const Model model = test::mixedBodies();
  Data data(model);
  std::mt19937 rng(2);
  crba(model, data, test::randomConfiguration(model, rng));
  const MatrixX m = denseMassMatrix(model, data);
  for (const Component& a : model.components)
    for (const Component& b : model.components) {
      if (&a != &b) {
        EXPECT_EQ(m.block(a.v_index, b.v_index, a.nv, b.nv).norm(), 0.0);
      }
    }
}

INSTANTIATE_TEST_SUITE_P(AllModels, CrbaTest, ::testing::Range(0, test::modelCount()),
                         test::modelName);

}  // namespace
}  // namespace sweep
