#include "framework/rnea.hpp"

#include <gtest/gtest.h>

#include "framework/configuration.hpp"
#include "framework/crba.hpp"
#include "framework/energy.hpp"
#include "framework/kinematics.hpp"
#include "test_models.hpp"

namespace sweep {
namespace {

class RneaTest : public test::ModelTest {};

MatrixX massAt(const Model& model, Data& data, const VectorX& q) {
  crba(model, data, q);
  return denseMassMatrix(model, data);
}

TEST_P(RneaTest, GravityIsGradientOfPotential) {
  // generalized gravity force g_i = dV(q (+) eps e_i)/d eps, valid for quaternions too
  const Model& model = *model_;
  Data data(model);
  std::mt19937 rng(17);
  const VectorX q = test::randomConfiguration(model, rng);
  const VectorX zero = VectorX::Zero(model.nv);
  const VectorX g = rnea(model, data, q, zero, zero);
  const double eps = 1e-6;
  for (int i = 0; i < model.nv; ++i) {
    const VectorX dv = eps * VectorX::Unit(model.nv, i);
    forwardKinematics(model, data, integrate(model, q, dv));
    const double plus = potentialEnergy(model, data);
    forwardKinematics(model, data, integrate(model, q, -dv));
    const double minus = potentialEnergy(model, data);
    EXPECT_NEAR(g[i], (plus - minus) / (2 * eps), 1e-7 * std::max(1.0, g.norm())) << "dof " << i;
  }
}

TEST_P(RneaTest, BiasEqualsChristoffelCoriolisPlusGravity) {
  // b_i = sum_jk (dM_ij/dq_k - 1/2 dM_jk/dq_i) v_j v_k + g_i  (valid where v = qdot)
  const Model& model = *model_;
  if (test::hasQuaternions(model)) GTEST_SKIP() << "quasi-velocities: v != qdot";
  Data data(model);
  std::mt19937 rng(19);
  const VectorX q = test::randomConfiguration(model, rng);
  const VectorX v = test::randomVector(model.nv, rng);
  const int n = model.nv;
  const double eps = 1e-6;
  std::vector<MatrixX> dm(n);
  for (int k = 0; k < n; ++k) {
    const VectorX dq = eps * VectorX::Unit(n, k);
    dm[k] = (massAt(model, data, q + dq) - massAt(model, data, q - dq)) / (2 * eps);
  }
  VectorX coriolis = VectorX::Zero(n);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k) coriolis[i] += (dm[k](i, j) - 0.5 * dm[i](j, k)) * v[j] * v[k];
  const VectorX zero = VectorX::Zero(n);
  const VectorX gravity = rnea(model, data, q, zero, zero);
  const VectorX bias = biasForces(model, data, q, v);
  EXPECT_LT((bias - gravity - coriolis).norm(), 1e-7 * std::max(1.0, coriolis.norm()));
}

TEST_P(RneaTest, PowerBalanceOfBias) {
  // v^T (C v) = 1/2 v^T Mdot v: the Coriolis terms do no net work beyond the change of M.
  // Holds for quaternion models too, with Mdot from q (+) eps v.
  const Model& model = *model_;
  Data data(model);
  std::mt19937 rng(23);
  const VectorX q = test::randomConfiguration(model, rng);
  const VectorX v = test::randomVector(model.nv, rng);
  const VectorX zero = VectorX::Zero(model.nv);
  // copies: both calls return a reference to data.tau
  const VectorX bias = biasForces(model, data, q, v);
  const VectorX gravity = rnea(model, data, q, zero, zero);
  const VectorX coriolis = bias - gravity;
  const double eps = 1e-6;
  const MatrixX mdot = (massAt(model, data, integrate(model, q, eps * v)) -
                        massAt(model, data, integrate(model, q, -eps * v))) /
                       (2 * eps);
  EXPECT_NEAR(v.dot(coriolis), 0.5 * v.dot(mdot * v), 1e-7 * std::max(1.0, coriolis.norm()));
}

TEST_P(RneaTest, GravityAndCoriolisComputedApartSumToTheBias) {
  const Model& model = *model_;
  Data data(model);
  std::mt19937 rng(29);
  const VectorX q = test::randomConfiguration(model, rng);
  const VectorX v = test::randomVector(model.nv, rng);
  const VectorX bias = biasForces(model, data, q, v);
  const VectorX gravity = gravityForces(model, data, q);
  const VectorX coriolis = coriolisForces(model, data, q, v);
  EXPECT_LT((gravity + coriolis - bias).norm(), 1e-12 * std::max(1.0, bias.norm()));
  const VectorX zero = VectorX::Zero(model.nv);
  EXPECT_EQ(gravity, VectorX(rnea(model, data, q, zero, zero)));
  // quadratic in v, and exactly zero without it
  const VectorX doubled = coriolisForces(model, data, q, 2.0 * v);
  EXPECT_LT((doubled - 4.0 * coriolis).norm(), 1e-12 * std::max(1.0, doubled.norm()));
  EXPECT_EQ(VectorX(coriolisForces(model, data, q, zero)), zero);
}

TEST_P(RneaTest, EnergiesAtAStateDoNotReadAnEarlierCallsKinematics) {
  const Model& model = *model_;
  Data data(model);
  std::mt19937 rng(31);
  const VectorX q = test::randomConfiguration(model, rng);
  const VectorX v = test::randomVector(model.nv, rng);
  const MatrixX M = massAt(model, data, q);
  // kinematics of another state left in data, as crba(q) alone would leave them
  forwardKinematics(model, data, test::randomConfiguration(model, rng),
                    test::randomVector(model.nv, rng));
  EXPECT_NEAR(kineticEnergy(model, data, q, v), 0.5 * v.dot(M * v), 1e-12 * v.squaredNorm());
  const double potential = potentialEnergy(model, data, q);
  const Vector3 com = centerOfMass(model, data, q);
  double mass = 0.0;
  for (const Body& b : model.bodies) mass += b.inertia.mass;
  EXPECT_NEAR(potential, -mass * model.gravity.dot(com),
              1e-12 * std::max(1.0, std::abs(potential)));
}

INSTANTIATE_TEST_SUITE_P(AllModels, RneaTest, ::testing::Range(0, test::modelCount()),
                         test::modelName);

}  // namespace
}  // namespace sweep
