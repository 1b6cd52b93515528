#pragma once
// The local updates of the NLGS solvers, each written once over the row adapters of
// integrators/rows.hpp (entry, packed 2D, packed 3D, compact sphere rows), with their
// natural-map residuals. Internal to integrators/.
//
// - coulombUpdate: scheme A's coupled law on row c (reference 2.3-2.5; Jean 1999),
//     q = U_c - W_cc P_c + (bias, 0, 0),  P_c <- argmin of the local Coulomb problem
//     (0 <= U*_N _|_ P_N >= 0 and Coulomb's law on P_T), relaxed by omega, then the rolling
//     rows: R_c <- argmin over |R| <= mu_r R* P_N of the local rolling problem.
// - normalUpdate: stage 5a on row c (reference 4.3): Lambda <- [Lambda - omega xi]_+ in the
//     scaled variables Lambda = s lambda, xi = U*_N / s, s^2 = W_NN.
// - FrictionStageRows::update: stage 5b on row c (reference 4.3; docs/schemes.md): the
//     rolling row, then either the guarded row's normal law or the friction law on the
//     tangential part of the motion, lambda_T in the disc |lambda_T| <= S_c, with the held
//     row's normal velocity kept at its stage-5a value (GLOBAL).
#include <algorithm>
#include <cmath>

#include "integrators/coulomb_local.hpp"
#include "integrators/friction_stage.hpp"
#include "integrators/rows.hpp"
#include "integrators/sweeps.hpp"

namespace sweep {

// The rolling rows' local solve on the disc |R| <= radius at rolling velocity u (2D: an
// interval): closed form where W_r is isotropic and the row knows it, else minimizeOnDisc.
template <class Row>
[[gnu::always_inline]] inline Vector2 rollingTargetOf(const Row& r, double radius, const Vector2& R,
                                                      const Vector2& u) {
  if (r.dimension() == 2)
    return Vector2(std::clamp(R.x() - u.x() / r.rollingW()(0, 0), -radius, radius), 0.0);
  if (r.rollingIsotropicInverse() > 0.0) {
    Vector2 target = R - u * r.rollingIsotropicInverse();
    const double norm2 = target.squaredNorm();
    if (norm2 > radius * radius) target *= radius / std::sqrt(norm2);
    return target;
  }
  return minimizeOnDisc(r.rollingW(), R, u, radius);
}

// One relaxed update of row r's rolling rows at rolling velocity u, bounded by
// rollingBound() times normal_impulse; returns dR. The changes enter the convergence measure
// in units of the bound's lever, so that torques weigh like forces.
template <class Row>
[[gnu::always_inline]] inline Vector2 rollingStepOf(const Row& r, double normal_impulse,
                                                    double omega, const Vector2& u, Vector2& R,
                                                    double& change2, double& size2) {
  const double radius = r.rollingBound() * std::max(normal_impulse, 0.0);
  const Vector2 dR = relaxedChange(rollingTargetOf(r, radius, R, u), R, omega);
  R += dR;
  const double lever2 = r.rollingBound() * r.rollingBound();
  change2 += dR.squaredNorm() / lever2;
  size2 += R.squaredNorm() / lever2;
  return dR;
}

// The upper-left 2 x 2 block of a local Delassus block (2D rows store only it).
inline const Matrix2& planar(const Matrix2& W) {
  return W;
}
inline Matrix2 planar(const Matrix3& W) {
  return W.topLeftCorner<2, 2>();
}
// W_TT, the tangential block; in 2D the second tangent is unused, kept invertible.
inline Matrix2 tangentBlock(const Matrix2& W) {
  Matrix2 A = Matrix2::Identity();
  A(0, 0) = W(1, 1);
  return A;
}
inline Matrix2 tangentBlock(const Matrix3& W, int dimension) {
  Matrix2 A = W.block<2, 2>(1, 1);
  if (dimension == 2) {
    A(0, 1) = A(1, 0) = 0.0;
    A(1, 1) = 1.0;
  }
  return A;
}
inline Matrix2 tangentBlock(const Matrix2& W, int) {
  return tangentBlock(W);
}
// W_NT, the normal row's tangential entries (2D: the second zero)
inline Vector2 normalTangentRow(const Matrix2& W) {
  return Vector2(W(0, 1), 0.0);
}
inline Vector2 normalTangentRow(const Matrix3& W) {
  return W.block<1, 2>(0, 1).transpose();
}

// q + (b, 0, 0) built whole: a store into one entry of a vector about to be read whole stalls
// the store forwarding (a sixth of the 2D sweep's time)
inline Vector2 withNormalShift(const Vector2& q, double b) {
  return Vector2(q.x() + b, q.y());
}
inline Vector3 withNormalShift(const Vector3& q, double b) {
  return Vector3(q.x() + b, q.y(), q.z());
}

// The second tangent's entry of a local vector (0 in 2D, and in the two lanes of a packed 2D
// row)
inline double secondTangent(const Vector2&, int) {
  return 0.0;
}
inline double secondTangent(const Vector3& u, int dimension) {
  return dimension == 3 ? u.z() : 0.0;
}

// Scheme A: one update of row r (impulse P, rolling impulse R or null) on v. An open row stays
// open: with P = 0 and R = 0 the local free velocity is U, and U_N + bias >= 0 makes every
// local solver return P = 0 (then R's disc has radius 0). On a screened powder pass 43 % of
// the updates are such rows; their normal velocity alone costs a fifth of the full one, and
// its sum runs in the full one's order.
template <class Row>
[[gnu::always_inline]] inline void coulombUpdate(const Row& r, double omega,
                                                 LocalSolver3d local_solver, Vector3& P_row,
                                                 Vector2* R, VectorX& v, double& change2,
                                                 double& size2, int& failures) {
  using Local = Eigen::Matrix<double, Row::kLocal, 1>;
  const bool rolling = R != nullptr && r.rollingBound() > 0.0;
  if (!r.isBilateral() && P_row.isZero(0.0) && (!rolling || R->isZero(0.0))) {
    if (r.normalVelocity(v) + r.bias() >= 0.0) return;
  }
  const Local P = P_row.template head<Row::kLocal>();
  Local u;
  Vector2 u_rolling = Vector2::Zero();
  r.velocity(v, u, u_rolling);
  const Local q = withNormalShift(r.freeVelocity(u, P), r.bias());
  Local P_new = Local::Zero();
  bool ok = true;
  if (r.mu() == 0.0) {
    P_new.x() = -q.x() * r.normalInverse();
    if (!r.isBilateral()) P_new.x() = std::max(P_new.x(), 0.0);
  } else if (r.dimension() == 2) {
    Vector2 P2;
    ok = solveCoulomb2d(planar(r.W()), planar(r.W_inverse()), q.template head<2>(), r.mu(), P2);
    P_new.template head<2>() = P2;
  } else if constexpr (Row::kSpatial) {
    if (local_solver == LocalSolver3d::Enumeration)
      ok = solveCoulomb3d(r.W(), r.W_inverse(), q, r.mu(), P_new);
    else
      ok = solveCoulomb3dNewton(r.W(), r.W_inverse(), q, r.mu(), P, P_new);
  }
  failures += ok ? 0 : 1;
  P_new = relaxedImpulse(P_new, P, omega);
  const Local dP = P_new - P;
  P_row.template head<Row::kLocal>() = P_new;
  change2 += dP.squaredNorm();
  size2 += P_new.squaredNorm();
  if constexpr (Row::kFusedRolling) {
    // the rolling velocity after the contact's own update is U_r + rollingChange(dP)
    Vector2 dR = Vector2::Zero();
    if (rolling)
      dR = rollingStepOf(r, P_new.x(), omega, u_rolling + r.rollingChange(dP), *R, change2, size2);
    r.apply(dP, dR, v);
  } else {
    r.apply(dP, Vector2::Zero(), v);
    if (rolling) {
      const Vector2 dR =
          rollingStepOf(r, P_new.x(), omega, r.rollingVelocity(v), *R, change2, size2);
      r.apply(Vector3::Zero(), dR, v);
    }
  }
}

// Scheme A's natural-map residual terms of row r, with rho = 1 / W_NN so that the residual is
// an impulse and comparable to P (Siconos mixes impulses and velocities).
template <class Row>
inline void coulombResidualTerms(const Row& r, const Vector3& P, const Vector2* R, const VectorX& v,
                                 double& f2, double& scale2) {
  Vector3 u;
  Vector2 u_rolling = Vector2::Zero();
  r.velocity(v, u, u_rolling);
  if (R != nullptr && r.rollingBound() > 0.0)
    rollingResidual({r.rollingBound(), r.rollingW()}, r.dimension(), P.x(), *R, u_rolling, f2,
                    scale2);
  u.x() += r.bias();
  const Vector3 ru = u / r.W_NN();
  if (r.isBilateral()) {  // the natural map of an equality: its velocity
    f2 += ru.x() * ru.x();
    scale2 += std::max(P.squaredNorm(), ru.squaredNorm());
    return;
  }
  // P = 0 with U*_N >= 0 meets the law: the cone's projection of -(U* + mu |U*_T| e_N) is
  // then zero in floating point too (U*_N + mu |U*_T| >= mu |U*_T|), and the map adds
  // nothing. A screened powder step's open rows, 40 % of its rows, skip the projection.
  if (!(P.isZero(0.0) && ru.x() >= 0.0))
    f2 += coulombNaturalMap(P, ru, r.mu(), r.dimension()).squaredNorm();
  scale2 += std::max(P.squaredNorm(), ru.squaredNorm());
}

// Stage 5a: one update of row r's normal impulse lambda. In the scaled variables the local
// problem has a unit diagonal, and Lambda <- [Lambda - omega xi]_+ is, in physical units, the
// clamp below; the sums are in the scaled norm.
template <class Row>
[[gnu::always_inline]] inline void normalUpdate(const Row& r, double omega, double& lambda,
                                                VectorX& v, double& change2, double& size2) {
  const double U_star = r.biasedNormalVelocity(v);
  double lambda_new = lambda - omega * U_star * r.complianceInverse();
  if (!r.isBilateral()) lambda_new = std::max(lambda_new, 0.0);
  const double d_lambda = lambda_new - lambda;
  r.applyNormal(d_lambda, v);
  lambda = lambda_new;
  const double W_NN = r.W_NN();
  change2 += W_NN * d_lambda * d_lambda;
  size2 += W_NN * lambda_new * lambda_new;
}

// Stage 5a's natural-map residual terms of row r (scaled variables).
template <class Row>
inline void normalResidualTerms(const Row& r, double lambda, const VectorX& v, double& f2,
                                double& scale2) {
  const double s = std::sqrt(r.W_NN());
  const double xi = (r.normalVelocity(v) + r.bias()) / s;
  const double Lambda = s * lambda;
  const double f = r.isBilateral() ? xi : Lambda - std::max(Lambda - xi, 0.0);
  f2 += f * f;
  scale2 += std::max(Lambda * Lambda, xi * xi);
}

// Stage 5b over the rows of one problem: its unknowns and per-contact setup, and the update
// and residual of one row.
struct FrictionStageRows {
  const ContactProblem& p;
  const FrictionStageOptions& options;
  const FrictionRowRule& rule;
  const SolverWorkspace& ws;  // threshold, held_normal, offset, coupling, schur
  const std::vector<double>& lambda_N;
  std::vector<double>& delta;
  std::vector<Vector2>& lambda_T;
  std::vector<Vector2>* R;
  double omega;

  [[gnu::always_inline]] bool hasRolling(double bound) const { return R != nullptr && bound > 0.0; }

  // impulse in (normal, tangents) whose generalized force is the chosen tangent times dl
  // (2D: the second tangent component of dl and of the coupling are zero)
  Vector3 tangentMap(int c, const Vector2& dl) const { return tangentMap<3>(c, dl, p.dimension); }
  template <int size>
  [[gnu::always_inline]] Eigen::Matrix<double, size, 1> tangentMap(int c, const Vector2& dl,
                                                                   int dimension) const {
    Eigen::Matrix<double, size, 1> dP = Eigen::Matrix<double, size, 1>::Zero();
    dP(1) = dl.x();
    if constexpr (size == 3) dP(2) = dimension == 3 ? dl.y() : 0.0;
    if (options.tangents == TangentMode::Local) dP.x() = -ws.coupling[c].dot(dl);
    return dP;
  }

  // A guarded row's projected Gauss-Seidel step on delta at normal velocity u_N: updates
  // delta and the sweep's measures, returns the change.
  [[gnu::always_inline]] double guardStep(int c, double u_N, double W_NN_inverse, double& change2,
                                          double& size2) const {
    const double target = std::max(delta[c] - (u_N + p.normal_bias[c]) * W_NN_inverse, 0.0);
    const double dd = std::max(delta[c] + omega * (target - delta[c]), 0.0) - delta[c];
    delta[c] += dd;
    change2 += dd * dd;
    size2 += delta[c] * delta[c];
    return dd;
  }

  // The tangential velocity the local problem acts on, its operator A, and (GLOBAL) the held
  // row's normal drift from its stage-5a velocity; true when the row is held (bilateral).
  template <class Row, class Local>
  [[gnu::always_inline]] bool tangentialPart(const Row& r, int c, const Local& u, Vector2& uT,
                                             Matrix2& A, double& drift) const {
    const Vector2& coupling = ws.coupling[c];
    uT = Vector2(u.y(), secondTangent(u, r.dimension())) - ws.offset[c];
    A = ws.schur[c];
    drift = 0.0;
    switch (options.tangents) {
      case TangentMode::Global:
        drift = u.x() - ws.held_normal[c];
        // eliminating the normal correction leaves the Schur complement
        uT -= coupling * drift;
        return rule.held(c);
      case TangentMode::Local:
        uT -= coupling * u.x();
        return false;
      case TangentMode::None:
        A = tangentBlock(r.W(), r.dimension());
        return false;
    }
    return false;
  }

  // The friction law's solution for lambda_T at (uT, A): the interval (2D), the METRIC bound's
  // ellipse as a disc in z = L^T lambda (3D), or the disc.
  template <class Row>
  [[gnu::always_inline]] Vector2 frictionTarget(const Row& r, int c, const Vector2& uT,
                                                const Matrix2& A) const {
    const double radius = ws.threshold[c];
    if (r.dimension() == 2)
      return Vector2(std::clamp(lambda_T[c].x() - uT.x() / A(0, 0), -radius, radius), 0.0);
    if constexpr (Row::kSpatial) return spatialFrictionTarget(r.W(), c, uT, A);
    return Vector2::Zero();  // a planar row has dimension 2
  }
  Vector2 spatialFrictionTarget(const Matrix3& W, int c, const Vector2& uT,
                                const Matrix2& A) const {
    double radius = ws.threshold[c];
    if (options.threshold == FrictionThreshold::Metric) {
      // ellipse lambda^T W_TT lambda <= (mu lambda_N)^2 W_NN: a disc in z = L^T lambda
      const Eigen::LLT<Matrix2> L(W.block<2, 2>(1, 1));
      const Matrix2 Lt = L.matrixU();
      const Matrix2 Lt_inv = Lt.inverse();
      radius *= std::sqrt(W(0, 0));
      const Vector2 z = minimizeOnDisc(Lt_inv.transpose() * A * Lt_inv, Lt * lambda_T[c],
                                       Lt_inv.transpose() * uT, radius);
      return Lt_inv * z;
    }
    if (radius > 0.0 && A(0, 1) == 0.0 && A(0, 0) == A(1, 1)) {
      // isotropic (compact sphere rows): minimizeOnDisc's Euclidean projection, with the
      // inverse taken apart from the velocity so that no division waits on the sweep; kept
      // out of minimizeOnDisc, whose isotropic branch scheme A's rolling rows and residuals
      // share with their own bits
      const Vector2 y = lambda_T[c] - uT * (1.0 / A(0, 0));
      const double norm = y.norm();
      return norm <= radius ? y : Vector2(y * (radius / norm));
    }
    return minimizeOnDisc(A, lambda_T[c], uT, radius);
  }

  // One update of row c: its rolling row (bounded by the stage-5a lambda_N like the friction),
  // then the guarded row's normal law or the friction law.
  template <class Row>
  [[gnu::always_inline]] void update(const Row& r, int c, VectorX& v, double& change2,
                                     double& size2) const {
    if constexpr (!Row::kSpatial) {
      planarUpdate(r, c, v, change2, size2);
      return;
    }
    const bool rolling_row = hasRolling(r.rollingBound());
    const bool guard_row = rule.guarded(c);
    const bool friction_row = ws.threshold[c] > 0.0 || rule.held(c);
    if (!rolling_row && !guard_row && !friction_row) return;
    using Local = Eigen::Matrix<double, Row::kLocal, 1>;
    Local u;
    Vector2 u_rolling = Vector2::Zero();
    Vector2 dR = Vector2::Zero();
    if constexpr (Row::kFusedRolling) {
      r.velocity(v, u, u_rolling);
      if (rolling_row) {
        dR = rollingStepOf(r, lambda_N[c], omega, u_rolling, (*R)[c], change2, size2);
        u += r.contactChange(dR);
      }
    } else {
      if (rolling_row) {
        r.apply(Vector3::Zero(),
                rollingStepOf(r, lambda_N[c], omega, r.rollingVelocity(v), (*R)[c], change2, size2),
                v);
      }
      Vector2 unused;
      r.velocity(v, u, unused);
    }
    Local dP = Local::Zero();
    if (guard_row) {
      dP.x() = guardStep(c, u.x(), r.complianceInverse(), change2, size2);
    } else if (friction_row) {
      Vector2 uT;
      Matrix2 A;
      double drift;
      const bool bilateral = tangentialPart(r, c, u, uT, A, drift);
      const Vector2 dl = omega * (frictionTarget(r, c, uT, A) - lambda_T[c]);
      dP = tangentMap<Row::kLocal>(c, dl, r.dimension());
      if (bilateral) {
        // keep this contact's normal velocity at its stage-5a value
        const double dd = -(drift + normalTangentRow(r.W()).dot(dl)) * r.complianceInverse();
        dP.x() += dd;
        delta[c] += dd;
      }
      lambda_T[c] += dl;
      change2 += dP.squaredNorm();
      size2 += lambda_T[c].squaredNorm() + delta[c] * delta[c];
    }
    r.apply(dP, dR, v);
  }

  // update() on a packed 2D row, whose one tangent makes every block a scalar: the same steps
  // and arithmetic in scalars, as vectors of two built entry by entry went through memory and
  // stalled the store forwarding (the 2D sweep took 1.6 times as long)
  template <class Row>
  [[gnu::always_inline]] void planarUpdate(const Row& r, int c, VectorX& v, double& change2,
                                           double& size2) const {
    const double radius = ws.threshold[c];
    const bool held = rule.held(c), guard_row = rule.guarded(c);
    if (radius <= 0.0 && !held && !guard_row) return;
    Vector2 u;
    Vector2 unused;
    r.velocity(v, u, unused);
    if (guard_row) {
      r.applyNormal(guardStep(c, u.x(), r.complianceInverse(), change2, size2), v);
      return;
    }
    const double coupling = ws.coupling[c].x();
    double uT = u.y() - ws.offset[c].x();
    double A = ws.schur[c](0, 0);
    double drift = 0.0;
    if (options.tangents == TangentMode::Global) {
      drift = u.x() - ws.held_normal[c];
      uT -= coupling * drift;
    } else if (options.tangents == TangentMode::Local) {
      uT -= coupling * u.x();
    } else {
      A = r.W()(1, 1);
    }
    const double lambda = lambda_T[c].x();
    const double dl = omega * (std::clamp(lambda - uT / A, -radius, radius) - lambda);
    double dN = options.tangents == TangentMode::Local ? -coupling * dl : 0.0;
    if (held) {
      const double dd = -(drift + r.W()(0, 1) * dl) * r.complianceInverse();
      dN += dd;
      delta[c] += dd;
    }
    r.apply(Vector2(dN, dl), Vector2::Zero(), v);
    lambda_T[c].x() = lambda + dl;
    change2 += dN * dN + dl * dl;
    size2 += (lambda + dl) * (lambda + dl) + delta[c] * delta[c];
  }

  // The natural-map residual terms of row c, in the units of the impulses.
  template <class Row>
  void residualTerms(const Row& r, int c, const VectorX& v, double& f2, double& scale2) const {
    Vector3 u;
    Vector2 u_rolling = Vector2::Zero();
    r.velocity(v, u, u_rolling);
    if (hasRolling(r.rollingBound()))
      rollingResidual({r.rollingBound(), r.rollingW()}, r.dimension(), lambda_N[c], (*R)[c],
                      u_rolling, f2, scale2);
    if (rule.guarded(c)) {
      // the natural map of the unilateral row, an impulse as in scheme A's residual
      const double xi = (u.x() + p.normal_bias[c]) / r.W_NN();
      const double f = delta[c] - std::max(delta[c] - xi, 0.0);
      f2 += f * f;
      scale2 += std::max(delta[c] * delta[c], xi * xi);
      return;
    }
    if (ws.threshold[c] <= 0.0 && !rule.held(c)) return;
    Vector2 uT;
    Matrix2 A;
    double drift;
    const bool bilateral = tangentialPart(r, c, u, uT, A, drift);
    const Vector2 f = lambda_T[c] - frictionTarget(r, c, uT, A);
    const double W_NN = r.W_NN();
    f2 += f.squaredNorm() + (bilateral ? drift * drift / (W_NN * W_NN) : 0.0);
    scale2 += std::max(lambda_T[c].squaredNorm(), (uT / A(0, 0)).squaredNorm());
    // the held normal row's residual is measured against the impulse that row carries, as
    // scheme A's natural map measures it against P_N
    if (bilateral && options.residual_scale_with_normal) {
      const double normal = lambda_N[c] + delta[c];
      scale2 += normal * normal;
    }
  }
};

// Stage 5b's admissible warm start on v: rows without a threshold carry no friction, and a
// guarded row pushes only, and only when something can move it (`any`: a row anywhere in the
// problem, over every rank, has friction or rolling; no sweep runs otherwise).
void warmStartFriction(const FrictionStageRows& stage, bool any, VectorX& v);

}  // namespace sweep
