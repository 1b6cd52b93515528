#include "integrators/coulomb_local.hpp"

#include <cmath>

namespace sweep {

bool solveCoulomb2d(const Matrix2& W, const Vector2& q, double mu, Vector2& P) {
  if (q.x() >= 0.0) {  // take-off
    P.setZero();
    return true;
  }
  // W is SPD: the 2x2 inverse in closed form
  const double det = W(0, 0) * W(1, 1) - W(0, 1) * W(1, 0);
  const Vector2 stick(-(W(1, 1) * q.x() - W(0, 1) * q.y()) / det,
                      -(W(0, 0) * q.y() - W(1, 0) * q.x()) / det);
  if (std::abs(stick.y()) <= mu * stick.x()) {
    P = stick;
    return true;
  }
  // slide, with sigma the sign of the post-step sliding velocity
  for (double sigma : {1.0, -1.0}) {
    const double den = W(0, 0) - sigma * mu * W(0, 1);
    if (den <= 0.0) continue;
    const double PN = -q.x() / den;
    const double PT = -sigma * mu * PN;
    if (sigma * (q.y() + W(1, 0) * PN + W(1, 1) * PT) >= 0.0) {
      P = Vector2(PN, PT);
      return true;
    }
  }
  P = Vector2(-q.x() / W(0, 0), 0.0);
  return false;
}

bool solveCoulomb3d(const Matrix3& W, const Vector3& q, double mu, Vector3& P) {
  if (q.x() >= 0.0) {
    P.setZero();
    return true;
  }
  const Vector3 stick = -W.ldlt().solve(q);
  if (stick.tail<2>().norm() <= mu * stick.x()) {
    P = stick;
    return true;
  }
  return slideCoulomb3d(W, q, mu, P);
}

bool slideCoulomb3d(const Matrix3& W, const Vector3& q, double mu, Vector3& P) {
  const double scale = W.diagonal().maxCoeff();
  const bool decoupled = std::abs(W(0, 1)) + std::abs(W(0, 2)) <= 1e-14 * scale;
  const bool isotropic =
      std::abs(W(1, 2)) <= 1e-14 * scale && std::abs(W(1, 1) - W(2, 2)) <= 1e-14 * scale;
  if (decoupled && isotropic) {
    // the sliding direction is that of the free tangential velocity
    P.x() = -q.x() / W(0, 0);
    const Vector2 qT = q.tail<2>();
    P.tail<2>() = -mu * P.x() * qT / qT.norm();
    return true;
  }
  // sliding along d(phi): P = P_N (1, -mu d), U_N = 0 fixes P_N, and the post-step sliding
  // velocity must be a positive multiple of d
  auto residual = [&](double phi, double& PN, double& along) {
    const Vector2 d(std::cos(phi), std::sin(phi));
    const double den = W(0, 0) - mu * (W(0, 1) * d.x() + W(0, 2) * d.y());
    if (den <= 0.0) {
      PN = -1.0;
      return 0.0;
    }
    PN = -q.x() / den;
    const Vector3 Pphi(PN, -mu * PN * d.x(), -mu * PN * d.y());
    const Vector2 UT = q.tail<2>() + (W * Pphi).tail<2>();
    along = d.dot(UT);
    return d.x() * UT.y() - d.y() * UT.x();
  };
  const int samples = 72;
  double best_PN = -1.0, best_phi = 0.0, previous_f = 0.0, previous_phi = 0.0;
  for (int s = 0; s <= samples; ++s) {
    const double phi = 2.0 * M_PI * s / samples;
    double PN = 0.0, along = 0.0;
    const double f = residual(phi, PN, along);
    if (s > 0 && PN > 0.0 && previous_f * f <= 0.0) {
      double lo = previous_phi, hi = phi, flo = previous_f;
      for (int it = 0; it < 60; ++it) {
        const double mid = 0.5 * (lo + hi);
        double pm = 0.0, am = 0.0;
        const double fm = residual(mid, pm, am);
        if ((fm <= 0.0) == (flo <= 0.0)) {
          lo = mid;
          flo = fm;
        } else {
          hi = mid;
        }
      }
      const double root = 0.5 * (lo + hi);
      double pr = 0.0, ar = 0.0;
      residual(root, pr, ar);
      if (pr > 0.0 && ar >= 0.0) {
        best_PN = pr;
        best_phi = root;
        break;
      }
    }
    previous_f = f;
    previous_phi = phi;
  }
  if (best_PN > 0.0) {
    P = Vector3(best_PN, -mu * best_PN * std::cos(best_phi), -mu * best_PN * std::sin(best_phi));
    return true;
  }
  P = Vector3(-q.x() / W(0, 0), 0.0, 0.0);
  return false;
}

namespace {

// Alart-Curnier residual F(P) and a generalized Jacobian J (reference 1.5)
double alartCurnier(const Matrix3& W, const Vector3& q, double mu, double rho_N, double rho_T,
                    const Vector3& P, Vector3& F, Matrix3* J) {
  const Vector3 U = W * P + q;
  const double r_N = P.x() - rho_N * U.x();
  Eigen::RowVector3d dr_N = -rho_N * W.row(0);
  dr_N(0) += 1.0;
  if (r_N <= 0.0) {
    F.x() = P.x();
    if (J) J->row(0) = Eigen::RowVector3d(1.0, 0.0, 0.0);
  } else {
    F.x() = rho_N * U.x();
    if (J) J->row(0) = rho_N * W.row(0);
  }
  const double radius = mu * std::max(r_N, 0.0);
  const Vector2 r_T = P.tail<2>() - rho_T * U.tail<2>();
  Eigen::Matrix<double, 2, 3> dr_T = -rho_T * W.bottomRows<2>();
  dr_T(0, 1) += 1.0;
  dr_T(1, 2) += 1.0;
  const double norm_T = r_T.norm();
  if (norm_T <= radius) {
    F.tail<2>() = rho_T * U.tail<2>();
    if (J) J->bottomRows<2>() = rho_T * W.bottomRows<2>();
  } else {
    const Vector2 dir = norm_T > 0.0 ? Vector2(r_T / norm_T) : Vector2::Zero();
    F.tail<2>() = P.tail<2>() - radius * dir;
    if (J) {
      Eigen::Matrix<double, 2, 3> d = Eigen::Matrix<double, 2, 3>::Zero();
      if (r_N > 0.0) d += dir * (mu * dr_N);
      if (norm_T > 0.0)
        d += (radius / norm_T) * (Matrix2::Identity() - dir * dir.transpose()) * dr_T;
      J->bottomRows<2>() = -d;
      (*J)(1, 1) += 1.0;
      (*J)(2, 2) += 1.0;
    }
  }
  return F.squaredNorm();
}

}  // namespace

bool solveCoulomb3dAlartCurnier(const Matrix3& W, const Vector3& q, double mu, Vector3& P,
                                double tolerance) {
  if (q.x() >= 0.0 && P.isZero(0.0)) {
    P.setZero();
    return true;
  }
  const double rho_N = 1.0 / W(0, 0);
  const double rho_T = 2.0 / (W(1, 1) + W(2, 2));
  const double scale = std::max(rho_N * q.norm(), 1e-300);
  const double target = tolerance * scale;
  Vector3 F;
  Matrix3 J;
  double merit = alartCurnier(W, q, mu, rho_N, rho_T, P, F, &J);
  for (int it = 0; it < 30 && std::sqrt(merit) > target; ++it) {
    const Vector3 step = J.fullPivLu().solve(-F);
    if (!step.allFinite()) break;
    // Armijo backtracking on |F|^2 / 2
    double t = 1.0;
    Vector3 trial_F;
    for (int ls = 0; ls < 20; ++ls, t *= 0.5) {
      const double trial = alartCurnier(W, q, mu, rho_N, rho_T, P + t * step, trial_F, nullptr);
      if (trial <= (1.0 - 1e-4 * t) * merit) break;
    }
    P += t * step;
    merit = alartCurnier(W, q, mu, rho_N, rho_T, P, F, &J);
  }
  if (std::sqrt(merit) <= target) return true;
  // fallback: projected fixed point on the De Saxce bipotential, P <- proj_K(P - rho Util)
  for (int it = 0; it < 500; ++it) {
    const Vector3 U = W * P + q;
    Vector3 util = U;
    util.x() += mu * U.tail<2>().norm();
    P = projectOnCone(P - rho_N * util, mu, 3);
    if (coulombNaturalMap(P, rho_N * U, mu, 3).norm() <= target) return true;
  }
  return false;
}

bool solveCoulomb3dNewton(const Matrix3& W, const Matrix3& W_inverse, const Vector3& q, double mu,
                          const Vector3& start, Vector3& P) {
  if (q.x() >= 0.0) {
    P.setZero();
    return true;
  }
  const Vector3 stick = -(W_inverse * q);
  if (stick.x() >= 0.0 &&
      stick.y() * stick.y() + stick.z() * stick.z() <= mu * mu * stick.x() * stick.x()) {
    P = stick;
    return true;
  }
  const double scale = W.diagonal().maxCoeff();
  if (std::abs(W(0, 1)) + std::abs(W(0, 2)) <= 1e-14 * scale &&
      std::abs(W(1, 2)) <= 1e-14 * scale && std::abs(W(1, 1) - W(2, 2)) <= 1e-14 * scale)
    return slideCoulomb3d(W, q, mu, P);  // closed form
  P = start;
  return solveCoulomb3dAlartCurnier(W, q, mu, P);
}

Vector3 projectOnCone(const Vector3& r, double mu, int dimension) {
  const double rT = dimension == 2 ? std::abs(r.y()) : r.tail<2>().norm();
  if (mu * rT <= -r.x()) return Vector3::Zero();
  if (rT <= mu * r.x()) return r;
  const double rN = (mu * rT + r.x()) / (mu * mu + 1.0);
  Vector3 out(rN, 0.0, 0.0);
  if (rT > 0.0) {
    out.y() = mu * rN * r.y() / rT;
    if (dimension == 3) out.z() = mu * rN * r.z() / rT;
  }
  return out;
}

Vector3 coulombNaturalMap(const Vector3& P, const Vector3& U_star, double mu, int dimension) {
  const double uT = dimension == 2 ? std::abs(U_star.y()) : U_star.tail<2>().norm();
  Vector3 util = U_star;
  util.x() += mu * uT;
  if (dimension == 2) util.z() = 0.0;
  return P - projectOnCone(P - util, mu, dimension);
}

}  // namespace sweep
