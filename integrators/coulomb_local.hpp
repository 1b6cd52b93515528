#pragma once
// Local Coulomb-Newton solves of one contact, U = W P + q with (reference sections 1.3-1.5)
//   take-off: P = 0, U_N >= 0;  stick: U = 0, |P_T| <= mu P_N;
//   slide: U_N = 0, P_T = -mu P_N U_T / |U_T|.
// q holds the local free velocity including the e-term and gap term of the normal law.
#include <cmath>

#include "framework/spatial.hpp"

namespace sweep {

// 2D: exact enumeration (LMGC90 mu_SC_std_solver, Siconos fc2d). Returns false when no
// sliding candidate is consistent (negative effective normal compliance, a local Painlevé
// case); P then holds the frictionless answer.
bool solveCoulomb2d(const Matrix2& W, const Vector2& q, double mu, Vector2& P);

// The same with W^-1 given (computed once per step): no division on the common paths.
inline bool solveCoulomb2d(const Matrix2& W, const Matrix2& W_inverse, const Vector2& q, double mu,
                           Vector2& P) {
  if (q.x() >= 0.0) {  // take-off
    P.setZero();
    return true;
  }
  const Vector2 stick = -(W_inverse * q);
  if (std::abs(stick.y()) <= mu * stick.x()) {
    P = stick;
    return true;
  }
  return solveCoulomb2d(W, q, mu, P);  // slide: the enumeration
}

// 3D: exact solve. Take-off and stick in closed form; sliding by the direction phi of the
// post-step sliding velocity, found by a sign scan and bisection of the parallelism
// condition (reference 2.3 (c)); isotropic decoupled blocks (spheres) in closed form.
bool solveCoulomb3d(const Matrix3& W, const Vector3& q, double mu, Vector3& P);

// The sliding branch alone (take-off and stick already excluded).
bool slideCoulomb3d(const Matrix3& W, const Vector3& q, double mu, Vector3& P);

// The same with W^-1 given: take-off and stick without a factorization.
inline bool solveCoulomb3d(const Matrix3& W, const Matrix3& W_inverse, const Vector3& q, double mu,
                           Vector3& P) {
  if (q.x() >= 0.0) {
    P.setZero();
    return true;
  }
  const Vector3 stick = -(W_inverse * q);
  if (stick.y() * stick.y() + stick.z() * stick.z() <= mu * mu * stick.x() * stick.x() &&
      stick.x() >= 0.0) {
    P = stick;
    return true;
  }
  return slideCoulomb3d(W, q, mu, P);
}

// 3D: Alart-Curnier nonsmooth Newton (Siconos variant, disc radius mu [P_N - rho U_N*]_+)
// from the starting value in P, with an Armijo line search on |F|^2 / 2; if it does not
// converge in 30 iterations, De Saxce projection fixed-point iterations (up to 500) take
// over. Returns false if neither reaches |F| <= tolerance * scale.
bool solveCoulomb3dAlartCurnier(const Matrix3& W, const Vector3& q, double mu, Vector3& P,
                                double tolerance = 1e-14);

// The production 3D solve: take-off and stick in closed form, sliding of decoupled isotropic
// blocks (spheres) in closed form, any other sliding by Alart-Curnier from `start` (the
// contact's previous impulse).
bool solveCoulomb3dNewton(const Matrix3& W, const Matrix3& W_inverse, const Vector3& q, double mu,
                          const Vector3& start, Vector3& P);

// Projection onto the cone {|P_T| <= mu P_N} (Siconos projectionOnCone), d = 2 or 3.
Vector3 projectOnCone(const Vector3& r, double mu, int dimension);

// Natural-map residual F = P - proj_K(P - Util), Util = (U_N* + mu |U_T|, U_T) (reference 1.6).
Vector3 coulombNaturalMap(const Vector3& P, const Vector3& U_star, double mu, int dimension);

}  // namespace sweep
