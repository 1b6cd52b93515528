#pragma once
// Local Coulomb-Newton solves of one contact, U = W P + q with (reference sections 1.3-1.5)
//   take-off: P = 0, U_N >= 0;  stick: U = 0, |P_T| <= mu P_N;
//   slide: U_N = 0, P_T = -mu P_N U_T / |U_T|.
// q holds the local free velocity including the e-term and gap term of the normal law.
#include "framework/spatial.hpp"

namespace sweep {

// 2D: exact enumeration (LMGC90 mu_SC_std_solver, Siconos fc2d). Returns false when no
// sliding candidate is consistent (negative effective normal compliance, a local Painlevé
// case); P then holds the frictionless answer.
bool solveCoulomb2d(const Matrix2& W, const Vector2& q, double mu, Vector2& P);

// 3D: exact solve. Take-off and stick in closed form; sliding by the direction phi of the
// post-step sliding velocity, found by a sign scan and bisection of the parallelism
// condition (reference 2.3 (c)); isotropic decoupled blocks (spheres) in closed form.
bool solveCoulomb3d(const Matrix3& W, const Vector3& q, double mu, Vector3& P);

// Projection onto the cone {|P_T| <= mu P_N} (Siconos projectionOnCone), d = 2 or 3.
Vector3 projectOnCone(const Vector3& r, double mu, int dimension);

// Natural-map residual F = P - proj_K(P - Util), Util = (U_N* + mu |U_T|, U_T) (reference 1.6).
Vector3 coulombNaturalMap(const Vector3& P, const Vector3& U_star, double mu, int dimension);

}  // namespace sweep
