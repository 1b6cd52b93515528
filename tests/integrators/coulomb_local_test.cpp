// The local Coulomb solves against each other and against the law itself.
#include "integrators/coulomb_local.hpp"

#include <gtest/gtest.h>

#include <random>

namespace sweep {
namespace {

// A random SPD local Delassus block with normal-tangent coupling, a random free velocity.
void randomProblem(std::mt19937& rng, Matrix3& W, Vector3& q, double& mu) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Matrix3 A;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) A(i, j) = u(rng);
  W = A * A.transpose() + 0.3 * Matrix3::Identity();
  // drawn last entry first, in sequence (a constructor's arguments have no order)
  const double q2 = u(rng), q1 = u(rng), q0 = u(rng);
  q = Vector3(q0, q1, q2);
  mu = 0.1 + 0.9 * (u(rng) + 1.0);
}

// The natural map of the Newton-Coulomb law vanishes at a solution.
double lawResidual(const Matrix3& W, const Vector3& q, double mu, const Vector3& P) {
  return coulombNaturalMap(P, (W * P + q) / W(0, 0), mu, 3).norm() / (1.0 + P.norm());
}

TEST(CoulombLocal3d, NewtonAndEnumerationSolveTheLaw) {
  std::mt19937 rng(17);
  int sliding = 0, agreed = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    Matrix3 W;
    Vector3 q;
    double mu = 0.0;
    randomProblem(rng, W, q, mu);
    Vector3 enumerated, newton;
    const bool ok_enum = solveCoulomb3d(W, q, mu, enumerated);
    const bool ok_newton = solveCoulomb3dNewton(W, W.inverse(), q, mu, Vector3::Zero(), newton);
    ASSERT_TRUE(ok_newton) << "trial " << trial;
    EXPECT_LT(lawResidual(W, q, mu, newton), 1e-10) << "trial " << trial;
    if (!ok_enum) continue;
    EXPECT_LT(lawResidual(W, q, mu, enumerated), 1e-9) << "trial " << trial;
    const Vector3 stick = -W.inverse() * q;
    if (q.x() < 0.0 && stick.tail<2>().norm() > mu * stick.x()) ++sliding;
    // both are solutions; where the law's solution is unique they coincide
    if ((newton - enumerated).norm() <= 1e-8 * (1.0 + newton.norm())) ++agreed;
  }
  EXPECT_GT(sliding, 300);
  EXPECT_GT(agreed, 1900);
}

TEST(CoulombLocal2d, EnumerationSolvesTheLaw) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 2000; ++trial) {
    Matrix3 W3;
    Vector3 q3;
    double mu = 0.0;
    randomProblem(rng, W3, q3, mu);
    const Matrix2 W = W3.topLeftCorner<2, 2>();
    const Vector2 q = q3.head<2>();
    Vector2 P;
    if (!solveCoulomb2d(W, q, mu, P)) continue;  // Painleve-type local inconsistency
    Vector3 P3(P.x(), P.y(), 0.0), U3(0, 0, 0);
    U3.head<2>() = (W * P + q) / W(0, 0);
    EXPECT_LT(coulombNaturalMap(P3, U3, mu, 2).norm() / (1.0 + P.norm()), 1e-12) << trial;
    Vector2 fast;
    solveCoulomb2d(W, W.inverse(), q, mu, fast);
    EXPECT_LT((fast - P).norm(), 1e-12 * (1.0 + P.norm()));
  }
}

}  // namespace
}  // namespace sweep
