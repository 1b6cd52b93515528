#include "integrators/interior_point.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>

#include "framework/parallel.hpp"
#include "integrators/sparse_cholesky.hpp"

namespace sweep {

namespace {

constexpr int kMaxIterations = 100;
// added to every diagonal entry of the Newton matrix (unit-diagonal units): keeps a singular A
// factorizable; the residuals are recomputed exactly each iteration, so it only damps the step
constexpr double kRegularization = 1e-9;
// the fraction of the step to the cone's boundary taken
constexpr double kStepFraction = 0.99;
// the smallest complementarity gap, relative to the first one, at which a step is taken
constexpr double kMuFloor = 1e-17;

// the largest alpha in [0, 1] with u + alpha d in the half-line (u > 0)
double halfLineStep(double u, double d) {
  return d < 0.0 ? std::min(1.0, -u / d) : 1.0;
}

// the largest alpha in [0, 1] with u + alpha d in the second-order cone (u inside): the
// smallest positive root of (u_0 + a d_0)^2 - |u_1 + a d_1|^2 = 0 with u_0 + a d_0 >= 0
double coneStep(const double* u, const double* d) {
  const double qa = d[0] * d[0] - d[1] * d[1] - d[2] * d[2];
  const double qb = 2.0 * (u[0] * d[0] - u[1] * d[1] - u[2] * d[2]);
  const double qc = u[0] * u[0] - u[1] * u[1] - u[2] * u[2];
  double alpha = 1.0;
  if (d[0] < 0.0) alpha = std::min(alpha, -u[0] / d[0]);
  if (std::abs(qa) < 1e-300) {
    if (qb < 0.0) alpha = std::min(alpha, -qc / qb);
    return alpha;
  }
  const double discriminant = qb * qb - 4.0 * qa * qc;
  if (discriminant < 0.0) return alpha;  // q keeps the sign of qc > 0
  // both roots without cancellation
  const double root = std::sqrt(discriminant);
  const double t = -0.5 * (qb + (qb >= 0.0 ? root : -root));
  for (double r : {t / qa, t != 0.0 ? qc / t : std::numeric_limits<double>::infinity()})
    if (r > 0.0) alpha = std::min(alpha, r);
  return alpha;
}

// u o v, the Jordan product of the cone: (u^T v, u_0 v_1 + v_0 u_1)
void jordanProduct(const double* u, const double* v, double* out) {
  out[0] = u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
  out[1] = u[0] * v[1] + v[0] * u[1];
  out[2] = u[0] * v[2] + v[0] * u[2];
}

// the u with lambda o u = r (lambda inside the cone)
void jordanDivide(const double* lambda, const double* r, double* u) {
  const double det = lambda[0] * lambda[0] - lambda[1] * lambda[1] - lambda[2] * lambda[2];
  u[0] = (lambda[0] * r[0] - lambda[1] * r[1] - lambda[2] * r[2]) / det;
  u[1] = (r[1] - u[0] * lambda[1]) / lambda[0];
  u[2] = (r[2] - u[0] * lambda[2]) / lambda[0];
}

// W y and W^-1 y for the cone's scaling W = eta (2 v v^T - J), W^-1 = (2 J v v^T J - J) / eta
void scale(double eta, const double* v, const double* y, double* out) {
  const double vy = v[0] * y[0] + v[1] * y[1] + v[2] * y[2];
  out[0] = eta * (2.0 * v[0] * vy - y[0]);
  out[1] = eta * (2.0 * v[1] * vy + y[1]);
  out[2] = eta * (2.0 * v[2] * vy + y[2]);
}
void unscale(double eta, const double* v, const double* y, double* out) {
  const double jvy = v[0] * y[0] - v[1] * y[1] - v[2] * y[2];  // (J v)^T y
  out[0] = (2.0 * v[0] * jvy - y[0]) / eta;
  out[1] = (-2.0 * v[1] * jvy + y[1]) / eta;
  out[2] = (-2.0 * v[2] * jvy + y[2]) / eta;
}

// The Nesterov-Todd scaling of the cone at (s, z), both inside: eta and v (CVXOPT's formulas)
void coneScaling(const double* s, const double* z, double& eta, double* v) {
  const double ns = std::sqrt(s[0] * s[0] - s[1] * s[1] - s[2] * s[2]);
  const double nz = std::sqrt(z[0] * z[0] - z[1] * z[1] - z[2] * z[2]);
  double sb[3], zb[3];
  for (int i = 0; i < 3; ++i) {
    sb[i] = s[i] / ns;
    zb[i] = z[i] / nz;
  }
  const double gamma = std::sqrt(0.5 * (1.0 + sb[0] * zb[0] + sb[1] * zb[1] + sb[2] * zb[2]));
  // the scaled NT point w = (s + J z) / (2 gamma), w^T J w = 1; v = (w + e) / sqrt(2 (w_0 + 1))
  const double w[3] = {(sb[0] + zb[0]) / (2.0 * gamma), (sb[1] - zb[1]) / (2.0 * gamma),
                       (sb[2] - zb[2]) / (2.0 * gamma)};
  const double norm = std::sqrt(2.0 * (w[0] + 1.0));
  v[0] = (w[0] + 1.0) / norm;
  v[1] = w[1] / norm;
  v[2] = w[2] / norm;
  eta = std::sqrt(ns / nz);
}

// One solve: the program as a cone program, its iterates and steps.
class InteriorPointSolve {
 public:
  InteriorPointSolve(const SeparableSet& set, const MprgpSettings& settings, std::vector<double>& x,
                     ProjectedNewtonWorkspace& newton, InteriorPointWorkspace& ws)
      : set_(set), settings_(settings), x_(x), newton_(newton), ws_(ws), n_(set.variables) {}

  // the cones, the diagonal's and discs' positions in A's pattern, the start; false when a
  // disc's two variables do not share an entry of A's pattern
  bool prepare() {
    ws_.lp_var.clear();
    ws_.lp_sign.clear();
    ws_.lp_h.clear();
    ws_.soc_var.clear();
    ws_.soc_r.clear();
    ws_.fixed.assign(n_, 0);
    for (int b = 0; b < set_.blocks(); ++b) {
      const int j = set_.first[b];
      switch (effectiveSet(set_, b)) {
        case BlockSet::Fixed:
          for (int k = 0; k < set_.size[b]; ++k) ws_.fixed[j + k] = 1;
          break;
        case BlockSet::Free:
          break;
        case BlockSet::NonNegative:
          addHalfLine(j, -1.0, 0.0);
          break;
        case BlockSet::Ball:
          if (set_.size[b] == 1) {
            addHalfLine(j, -1.0, set_.radius[b]);
            addHalfLine(j, 1.0, set_.radius[b]);
          } else {
            ws_.soc_var.push_back(j);
            ws_.soc_r.push_back(set_.radius[b]);
          }
          break;
      }
    }
    const int lp = static_cast<int>(ws_.lp_var.size()), soc = static_cast<int>(ws_.soc_var.size());
    for (std::vector<double>* w : {&ws_.lp_s, &ws_.lp_z, &ws_.lp_ds, &ws_.lp_dz, &ws_.lp_ds_affine,
                                   &ws_.lp_dz_affine, &ws_.lp_d})
      w->resize(lp);
    for (std::vector<double>* w : {&ws_.soc_s, &ws_.soc_z, &ws_.soc_ds, &ws_.soc_dz,
                                   &ws_.soc_ds_affine, &ws_.soc_dz_affine, &ws_.soc_d, &ws_.soc_v})
      w->resize(3 * soc);
    ws_.soc_eta.resize(soc);
    for (std::vector<double>* w : {&ws_.r_x, &ws_.rhs, &ws_.dx, &ws_.x_trial, &ws_.g})
      w->resize(n_);
    // A's diagonal heads each column (rows sorted, i >= j); a disc's (j + 1, j) entry follows
    ws_.diagonal.resize(n_);
    for (int j = 0; j < n_; ++j) ws_.diagonal[j] = newton_.a_begin[j];
    ws_.soc_offdiagonal.resize(soc);
    for (int c = 0; c < soc; ++c) {
      const int j = ws_.soc_var[c];
      const int e = newton_.a_begin[j] + 1;
      if (e >= newton_.a_begin[j + 1] || newton_.a_row[e] != j + 1) return false;
      ws_.soc_offdiagonal[c] = e;
    }
    degree_ = lp + soc;
    // the start: x projected, s and z at kappa e, kappa the size of the gradient at x = 0
    project(set_, x_);
    double kappa = 0.0;
    for (double value : newton_.b) kappa = std::max(kappa, std::abs(value));
    for (double r : ws_.soc_r) kappa = std::max(kappa, r);
    for (double h : ws_.lp_h) kappa = std::max(kappa, h);
    if (!(kappa > 0.0)) kappa = 1.0;
    std::fill(ws_.lp_s.begin(), ws_.lp_s.end(), kappa);
    std::fill(ws_.lp_z.begin(), ws_.lp_z.end(), kappa);
    for (int c = 0; c < soc; ++c)
      for (int i = 0; i < 3; ++i) {
        ws_.soc_s[3 * c + i] = i == 0 ? kappa : 0.0;
        ws_.soc_z[3 * c + i] = i == 0 ? kappa : 0.0;
      }
    return true;
  }

  // Iterations to the tolerance, the cap or a failed factorization; returns whether it met the
  // tolerance
  bool iterate() {
    const int cap = std::min(kMaxIterations, settings_.max_iterations);
    double best = std::numeric_limits<double>::infinity();
    bool met = false;
    for (;;) {
      delassusGradient(newton_, x_, ws_.g, settings_.threads);
      const double residual = naturalResidual(set_, x_, ws_.g);
      if (residual < best) {
        best = residual;
        ws_.x_trial = x_;
      }
      if (residual <= settings_.tolerance) {
        met = true;
        break;
      }
      if (stats.iterations >= cap || !step()) break;
      ++stats.iterations;
    }
    x_ = ws_.x_trial;
    stats.residual = best;
    return met;
  }

  MprgpStats stats;

 private:
  void addHalfLine(int j, double sign, double h) {
    ws_.lp_var.push_back(j);
    ws_.lp_sign.push_back(sign);
    ws_.lp_h.push_back(h);
  }

  // One predictor-corrector step; false when the Newton matrix cannot be factorized.
  bool step() {
    const int lp = static_cast<int>(ws_.lp_var.size()), soc = static_cast<int>(ws_.soc_var.size());
    // the scaling, and mu = s^T z / degree
    double gap = 0.0;
    for (int k = 0; k < lp; ++k) gap += ws_.lp_s[k] * ws_.lp_z[k];
    for (int c = 0; c < soc; ++c) {
      const double* s = &ws_.soc_s[3 * c];
      const double* z = &ws_.soc_z[3 * c];
      gap += s[0] * z[0] + s[1] * z[1] + s[2] * z[2];
      coneScaling(s, z, ws_.soc_eta[c], &ws_.soc_v[3 * c]);
      if (!(ws_.soc_eta[c] > 0.0 && std::isfinite(ws_.soc_eta[c]))) return false;
    }
    const double mu = degree_ > 0 ? gap / degree_ : 0.0;
    // past this, s and z lose their last digits (and their cones' interiors) to round-off
    if (stats.iterations == 0) mu_start_ = mu;
    if (degree_ > 0 && !(mu > kMuFloor * mu_start_)) return false;
    // the dual residual r_x = A x + b + G^T z (ws_.g holds A x + b)
    ws_.r_x = ws_.g;
    for (int k = 0; k < lp; ++k) ws_.r_x[ws_.lp_var[k]] += ws_.lp_sign[k] * ws_.lp_z[k];
    for (int c = 0; c < soc; ++c) {
      ws_.r_x[ws_.soc_var[c]] -= ws_.soc_z[3 * c + 1];
      ws_.r_x[ws_.soc_var[c] + 1] -= ws_.soc_z[3 * c + 2];
    }
    if (!factorize()) return false;
    // predictor: the affine direction (complementarity target 0)
    direction(false, 0.0, 0.0);
    std::copy(ws_.lp_ds.begin(), ws_.lp_ds.end(), ws_.lp_ds_affine.begin());
    std::copy(ws_.lp_dz.begin(), ws_.lp_dz.end(), ws_.lp_dz_affine.begin());
    std::copy(ws_.soc_ds.begin(), ws_.soc_ds.end(), ws_.soc_ds_affine.begin());
    std::copy(ws_.soc_dz.begin(), ws_.soc_dz.end(), ws_.soc_dz_affine.begin());
    const double alpha_affine = stepLength();
    // Mehrotra's centring: sigma = (1 - alpha)^3, as CVXOPT's coneqp
    const double sigma = std::pow(1.0 - alpha_affine, 3);
    // corrector: the combined direction, with the second-order term of the affine one
    direction(true, sigma, mu);
    const double alpha = std::min(1.0, kStepFraction * stepLength());
    for (int j = 0; j < n_; ++j) x_[j] += alpha * ws_.dx[j];
    for (int k = 0; k < lp; ++k) {
      ws_.lp_s[k] += alpha * ws_.lp_ds[k];
      ws_.lp_z[k] += alpha * ws_.lp_dz[k];
    }
    for (int i = 0; i < 3 * soc; ++i) {
      ws_.soc_s[i] += alpha * ws_.soc_ds[i];
      ws_.soc_z[i] += alpha * ws_.soc_dz[i];
    }
    return true;
  }

  // The Newton matrix A + G^T W^-2 G (+ regularization; identity on fixed variables), factorized
  bool factorize() {
    std::vector<double>& value = newton_.factor_value;
    const std::vector<double>& a = newton_.a_value;
    for (int j = 0; j < n_; ++j)
      for (int e = newton_.a_begin[j]; e < newton_.a_begin[j + 1]; ++e) {
        const int i = newton_.a_row[e];
        if (ws_.fixed[i] || ws_.fixed[j])
          value[e] = i == j ? 1.0 : 0.0;
        else
          value[e] = a[e] + (i == j ? kRegularization : 0.0);
      }
    for (int k = 0; k < static_cast<int>(ws_.lp_var.size()); ++k)
      value[ws_.diagonal[ws_.lp_var[k]]] += ws_.lp_z[k] / ws_.lp_s[k];
    for (int c = 0; c < static_cast<int>(ws_.soc_var.size()); ++c) {
      // W^-2 = W^-1 W^-1, its lower-right 2 x 2 block (G = [0; -I]: G^T W^-2 G)
      const double eta = ws_.soc_eta[c];
      const double* v = &ws_.soc_v[3 * c];
      double column1[3], column2[3];
      const double e1[3] = {0.0, 1.0, 0.0}, e2[3] = {0.0, 0.0, 1.0};
      double t[3];
      unscale(eta, v, e1, t);
      unscale(eta, v, t, column1);
      unscale(eta, v, e2, t);
      unscale(eta, v, t, column2);
      const int j = ws_.soc_var[c];
      value[ws_.diagonal[j]] += column1[1];
      value[ws_.diagonal[j + 1]] += column2[2];
      value[ws_.soc_offdiagonal[c]] += column1[2];
    }
    return newton_.cholesky->factorize(value);
  }

  // The direction for the complementarity target lambda o lambda -> sigma mu e, with
  // Mehrotra's correction (W^-1 ds_affine) o (W dz_affine) when `corrected`: dx, ds, dz.
  void direction(bool corrected, double sigma, double mu) {
    const int lp = static_cast<int>(ws_.lp_var.size()), soc = static_cast<int>(ws_.soc_var.size());
    // rhs = -r_x - G^T W^-2 (r_z + W d_s), d_s = lambda \ r_c, r_z = s + G x - h
    for (int j = 0; j < n_; ++j) ws_.rhs[j] = -ws_.r_x[j];
    for (int k = 0; k < lp; ++k) {
      const double s = ws_.lp_s[k], z = ws_.lp_z[k];
      const double lambda = std::sqrt(s * z), w = std::sqrt(s / z);
      double r_c = -lambda * lambda;
      if (corrected) r_c += sigma * mu - (ws_.lp_ds_affine[k] / w) * (ws_.lp_dz_affine[k] * w);
      ws_.lp_d[k] = r_c / lambda;  // d_s
      const double r_z = s + ws_.lp_sign[k] * x_[ws_.lp_var[k]] - ws_.lp_h[k];
      ws_.lp_dz[k] = r_z + w * ws_.lp_d[k];  // r_z + W d_s, for now
      ws_.rhs[ws_.lp_var[k]] -= ws_.lp_sign[k] * (z / s) * ws_.lp_dz[k];
    }
    for (int c = 0; c < soc; ++c) {
      const double* s = &ws_.soc_s[3 * c];
      const double eta = ws_.soc_eta[c];
      const double* v = &ws_.soc_v[3 * c];
      const int j = ws_.soc_var[c];
      double lambda[3], lambda2[3], r_c[3];
      scale(eta, v, &ws_.soc_z[3 * c], lambda);
      jordanProduct(lambda, lambda, lambda2);
      for (int i = 0; i < 3; ++i) r_c[i] = -lambda2[i];
      if (corrected) {
        double a[3], b[3], ab[3];
        unscale(eta, v, &ws_.soc_ds_affine[3 * c], a);
        scale(eta, v, &ws_.soc_dz_affine[3 * c], b);
        jordanProduct(a, b, ab);
        for (int i = 0; i < 3; ++i) r_c[i] -= ab[i];
        r_c[0] += sigma * mu;
      }
      double* d = &ws_.soc_d[3 * c];
      jordanDivide(lambda, r_c, d);
      double wd[3], u[3], t[3];
      scale(eta, v, d, wd);
      const double r_z[3] = {s[0] - ws_.soc_r[c], s[1] - x_[j], s[2] - x_[j + 1]};
      for (int i = 0; i < 3; ++i) u[i] = r_z[i] + wd[i];
      double* keep = &ws_.soc_dz[3 * c];  // r_z + W d_s, for now
      for (int i = 0; i < 3; ++i) keep[i] = u[i];
      unscale(eta, v, u, t);
      unscale(eta, v, t, u);  // W^-2 (r_z + W d_s)
      ws_.rhs[j] += u[1];     // - G^T: G^T y = (-y_1, -y_2)
      ws_.rhs[j + 1] += u[2];
    }
    for (int j = 0; j < n_; ++j)
      if (ws_.fixed[j]) ws_.rhs[j] = 0.0;
    newton_.cholesky->solve(ws_.rhs, ws_.dx);
    // dz = W^-2 (G dx + r_z + W d_s), ds = W (d_s - W dz)
    for (int k = 0; k < lp; ++k) {
      const double s = ws_.lp_s[k], z = ws_.lp_z[k], w = std::sqrt(s / z);
      const double dz = (z / s) * (ws_.lp_sign[k] * ws_.dx[ws_.lp_var[k]] + ws_.lp_dz[k]);
      ws_.lp_dz[k] = dz;
      ws_.lp_ds[k] = w * (ws_.lp_d[k] - w * dz);
    }
    for (int c = 0; c < soc; ++c) {
      const double eta = ws_.soc_eta[c];
      const double* v = &ws_.soc_v[3 * c];
      const int j = ws_.soc_var[c];
      double* dz = &ws_.soc_dz[3 * c];
      double u[3] = {dz[0], dz[1] - ws_.dx[j], dz[2] - ws_.dx[j + 1]}, t[3];
      unscale(eta, v, u, t);
      unscale(eta, v, t, dz);
      double wdz[3], r[3];
      scale(eta, v, dz, wdz);
      const double* d = &ws_.soc_d[3 * c];
      for (int i = 0; i < 3; ++i) r[i] = d[i] - wdz[i];
      scale(eta, v, r, &ws_.soc_ds[3 * c]);
    }
  }

  // the largest step in [0, 1] that keeps s and z in their cones
  double stepLength() const {
    double alpha = 1.0;
    for (int k = 0; k < static_cast<int>(ws_.lp_var.size()); ++k) {
      alpha = std::min(alpha, halfLineStep(ws_.lp_s[k], ws_.lp_ds[k]));
      alpha = std::min(alpha, halfLineStep(ws_.lp_z[k], ws_.lp_dz[k]));
    }
    for (int c = 0; c < static_cast<int>(ws_.soc_var.size()); ++c) {
      alpha = std::min(alpha, coneStep(&ws_.soc_s[3 * c], &ws_.soc_ds[3 * c]));
      alpha = std::min(alpha, coneStep(&ws_.soc_z[3 * c], &ws_.soc_dz[3 * c]));
    }
    return alpha;
  }

  const SeparableSet& set_;
  const MprgpSettings& settings_;
  std::vector<double>& x_;
  ProjectedNewtonWorkspace& newton_;
  InteriorPointWorkspace& ws_;
  const int n_;
  int degree_ = 0;
  double mu_start_ = 0.0;
};

}  // namespace

bool interiorPointApplies(const SeparableSet& set) {
  for (int b = 0; b < set.blocks(); ++b) {
    const BlockSet kind = effectiveSet(set, b);
    if (kind == BlockSet::NonNegative && set.size[b] != 1) return false;
    if (kind == BlockSet::Ball && set.size[b] > 2) return false;
  }
  return true;
}

MprgpStats solveInteriorPoint(const QpOperator& op, const SeparableSet& set,
                              const MprgpSettings& settings, std::vector<double>& x, VectorX& v,
                              ProjectedNewtonWorkspace& newton, InteriorPointWorkspace& ws,
                              MprgpWorkspace& fallback) {
  const int n = set.variables;
  x.resize(n);
  newton.J.clear();
  newton.K.clear();
  if (n == 0 || !op.columns(newton.J, newton.K) || newton.J.columns() != n ||
      newton.K.columns() != n)
    return solveSeparableQp(op, set, settings, x, v, fallback);
  newton.b.resize(n);
  op.toGradient(v, true, newton.b);  // b: the gradient at x = 0
  formDelassus(newton, set, static_cast<int>(v.size()));
  if (!newton.cholesky) newton.cholesky = std::make_unique<SparseCholesky>();
  newton.factor_value.resize(newton.a_value.size());
  InteriorPointSolve solve(set, settings, x, newton, ws);
  bool converged = false;
  if (newton.cholesky->analyze(n, newton.a_begin, newton.a_row, settings.threads) &&
      solve.prepare())
    converged = solve.iterate();
  MprgpStats stats = solve.stats;
  stats.products = 1;
  stats.newton_steps = stats.iterations;
  project(set, x);  // the iterate is inside its set; round-off aside, so is its projection

  if (acceptDirectAnswer(op, set, settings, x, converged, v, ws.g, fallback, stats)) return stats;
  // MPRGP / APGD for the digits left, from the best iterate (feasible, and no farther from the
  // answer than the warm start it began at), with the iterations left
  MprgpSettings rest = settings;
  rest.max_iterations = std::max(1, settings.max_iterations - stats.iterations);
  MprgpStats total = solveSeparableQp(op, set, rest, x, v, fallback);
  total.iterations += stats.iterations;
  total.products += stats.products;
  total.newton_steps = stats.newton_steps;
  return total;
}

}  // namespace sweep
