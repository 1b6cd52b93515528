#include "integrators/projected_newton.hpp"

#include <cholmod.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace sweep {

namespace {

// Newton steps before the solve is handed to MPRGP: a warm-started solve needs a handful, but
// damped steps on GLOBAL's redundant held rows took up to 67 on the 50 000-disk funnel (with
// 50, MPRGP then hit its cap on 60 steps); more means a program the Newton steps do not suit
// (no solution)
constexpr int kMaxNewton = 200;
// rho, the proximal term added to A_FF (unit-diagonal units; projected_newton.hpp). Measured
// on the 5000-disk funnel: 1e-10 handed 69 steps' stage 5b to MPRGP, 1e-8 29, 1e-6 2, 1e-4 and
// 1e-3 none (and took the same time within the machine's noise)
constexpr double kRegularization = 1e-4;
// the largest binding margin eps (unit-diagonal units)
constexpr double kBindingMargin = 1e-3;
constexpr double kArmijo = 1e-4;
constexpr int kMaxHalvings = 40;
constexpr char kFree = 0, kLower = 1, kUpper = 2;

}  // namespace

// CHOLMOD's common block, the fill-reducing permutation, the matrix permuted into CHOLMOD's
// own working form and the symbolic and numeric factor, all kept between solves. The matrix
// is permuted here, once per pattern, so that each numeric factorization reads it in place:
// CHOLMOD's simplicial factorization of a matrix with a permutation would build a transposed,
// permuted copy every time (an allocation inside the solver's iterations and, measured, 7 % of
// the 500-disk funnel's run). A pattern equal to the last one's reuses all of it.
class SparseCholesky {
 public:
  SparseCholesky() {
    cholmod_start(&common_);
    common_.print = 0;
    common_.error_handler = nullptr;
    // the matrix given to cholmod_analyze is already in AMD order; no postorder, which would
    // permute it again
    common_.nmethods = 1;
    common_.method[0].ordering = CHOLMOD_NATURAL;
    common_.postorder = 0;
    // simplicial factors need no BLAS, whose threaded builds would make the bits depend on
    // the machine; the contact networks' factors are too sparse for supernodes to pay
    common_.supernodal = CHOLMOD_SIMPLICIAL;
    common_.final_ll = 0;
  }
  ~SparseCholesky() {
    release();
    cholmod_free_dense(&x_, &common_);
    cholmod_free_dense(&y_, &common_);
    cholmod_free_dense(&e_, &common_);
    cholmod_finish(&common_);
  }
  SparseCholesky(const SparseCholesky&) = delete;
  SparseCholesky& operator=(const SparseCholesky&) = delete;

  void release() {
    if (factor_ != nullptr) cholmod_free_factor(&factor_, &common_);
  }

  // The ordering (AMD, on A + A^T) and the symbolic factorization of the n x n matrix whose
  // lower triangle has the compressed columns (begin, row), rows sorted; kept when the
  // pattern is the last one's.
  bool analyze(int n, const std::vector<int>& begin, const std::vector<int>& row) {
    if (factor_ != nullptr && n == n_ && begin == begin_ && row == row_) return true;
    release();
    n_ = n;
    begin_ = begin;
    row_ = row;
    const int entries = static_cast<int>(row.size());
    cholmod_sparse lower = view(n, begin_, row_, nullptr, -1);
    permutation_.resize(n);
    if (!cholmod_amd(&lower, nullptr, 0, permutation_.data(), &common_)) return false;
    inverse_.resize(n);
    for (int k = 0; k < n; ++k) inverse_[permutation_[k]] = k;
    // the upper triangle of P A P^T by columns, rows sorted, and where each entry of A goes
    upper_begin_.assign(n + 1, 0);
    for (int j = 0; j < n; ++j)
      for (int e = begin[j]; e < begin[j + 1]; ++e)
        ++upper_begin_[std::max(inverse_[row[e]], inverse_[j]) + 1];
    for (int j = 0; j < n; ++j) upper_begin_[j + 1] += upper_begin_[j];
    slots_.resize(entries);
    fill_.assign(upper_begin_.begin(), upper_begin_.end() - 1);
    for (int j = 0; j < n; ++j)
      for (int e = begin[j]; e < begin[j + 1]; ++e) {
        const int a = inverse_[row[e]], b = inverse_[j];
        slots_[fill_[std::max(a, b)]++] = {std::min(a, b), e};
      }
    upper_row_.resize(entries);
    to_upper_.resize(entries);
    for (int j = 0; j < n; ++j) {
      std::sort(slots_.begin() + upper_begin_[j], slots_.begin() + upper_begin_[j + 1]);
      for (int k = upper_begin_[j]; k < upper_begin_[j + 1]; ++k) {
        upper_row_[k] = slots_[k].first;
        to_upper_[slots_[k].second] = k;
      }
    }
    upper_value_.assign(entries, 0.0);
    upper_ = view(n, upper_begin_, upper_row_, upper_value_.data(), 1);
    factor_ = cholmod_analyze(&upper_, &common_);
    return factor_ != nullptr && common_.status == CHOLMOD_OK &&
           factor_->ordering == CHOLMOD_NATURAL;
  }
  // the numeric factorization of the matrix with these values (in the order of `row`)
  bool factorize(const std::vector<double>& value) {
    for (std::size_t e = 0; e < value.size(); ++e) upper_value_[to_upper_[e]] = value[e];
    const int ok = cholmod_factorize(&upper_, factor_, &common_);
    return ok && common_.status == CHOLMOD_OK && factor_->minor == factor_->n;
  }
  // solution = A^-1 rhs
  bool solve(const std::vector<double>& rhs, std::vector<double>& solution) {
    permuted_.resize(rhs.size());
    for (int i = 0; i < n_; ++i) permuted_[inverse_[i]] = rhs[i];
    cholmod_dense b{};
    b.nrow = permuted_.size();
    b.ncol = 1;
    b.nzmax = permuted_.size();
    b.d = permuted_.size();
    b.x = permuted_.data();
    b.xtype = CHOLMOD_REAL;
    b.dtype = CHOLMOD_DOUBLE;
    if (!cholmod_solve2(CHOLMOD_A, factor_, &b, nullptr, &x_, nullptr, &y_, &e_, &common_))
      return false;
    const double* x = static_cast<const double*>(x_->x);
    for (int i = 0; i < n_; ++i) solution[i] = x[inverse_[i]];
    return true;
  }

 private:
  // a CHOLMOD view of compressed columns (values null: the pattern alone)
  static cholmod_sparse view(int n, std::vector<int>& begin, std::vector<int>& row, double* value,
                             int stype) {
    cholmod_sparse m{};
    m.nrow = m.ncol = static_cast<size_t>(n);
    m.nzmax = row.size();
    m.p = begin.data();
    m.i = row.data();
    m.x = value;
    m.stype = stype;
    m.itype = CHOLMOD_INT;
    m.xtype = value != nullptr ? CHOLMOD_REAL : CHOLMOD_PATTERN;
    m.dtype = CHOLMOD_DOUBLE;
    m.sorted = 1;
    m.packed = 1;
    return m;
  }

  cholmod_common common_{};
  int n_ = -1;
  std::vector<int> begin_, row_;  // the analysed pattern (lower triangle of A)
  std::vector<int> permutation_, inverse_;
  std::vector<int> upper_begin_, upper_row_, to_upper_, fill_;
  std::vector<std::pair<int, int>> slots_;
  std::vector<double> upper_value_, permuted_;
  cholmod_sparse upper_{};
  cholmod_factor* factor_ = nullptr;
  cholmod_dense *x_ = nullptr, *y_ = nullptr, *e_ = nullptr;
};

ProjectedNewtonWorkspace::ProjectedNewtonWorkspace() = default;
ProjectedNewtonWorkspace::~ProjectedNewtonWorkspace() = default;
ProjectedNewtonWorkspace::ProjectedNewtonWorkspace(ProjectedNewtonWorkspace&&) noexcept = default;
ProjectedNewtonWorkspace& ProjectedNewtonWorkspace::operator=(ProjectedNewtonWorkspace&&) noexcept =
    default;

bool projectedNewtonApplies(const SeparableSet& set) {
  for (int b = 0; b < set.blocks(); ++b)
    if (set.size[b] != 1 && effectiveSet(set, b) != BlockSet::Fixed) return false;
  return true;
}

namespace {

// A = J^T K, lower triangle: Gustavson's product over J by velocity.
void formProduct(ProjectedNewtonWorkspace& ws, int n, int velocities) {
  const SparseColumns &J = ws.J, &K = ws.K;
  // J by velocity (a counting sort of its entries)
  ws.by_dof_begin.assign(velocities + 1, 0);
  for (int r : J.row) ++ws.by_dof_begin[r + 1];
  for (int k = 0; k < velocities; ++k) ws.by_dof_begin[k + 1] += ws.by_dof_begin[k];
  ws.by_dof_variable.resize(J.row.size());
  ws.by_dof_value.resize(J.row.size());
  ws.touched.assign(ws.by_dof_begin.begin(), ws.by_dof_begin.end() - 1);  // fill positions
  for (int j = 0; j < n; ++j)
    for (int e = J.begin[j]; e < J.begin[j + 1]; ++e) {
      const int slot = ws.touched[J.row[e]]++;
      ws.by_dof_variable[slot] = j;
      ws.by_dof_value[slot] = J.value[e];
    }
  // column j of A: sum over K's entries (k, K_kj) of J's row k times K_kj, rows i >= j
  ws.accumulator.assign(n, 0.0);
  ws.marker.assign(n, -1);
  ws.touched.clear();
  ws.a_begin.assign(1, 0);
  ws.a_row.clear();
  ws.a_value.clear();
  for (int j = 0; j < n; ++j) {
    ws.touched.clear();
    ws.marker[j] = j;  // the diagonal always, so that every column has a pivot
    ws.touched.push_back(j);
    for (int e = K.begin[j]; e < K.begin[j + 1]; ++e) {
      const int k = K.row[e];
      const double kv = K.value[e];
      for (int s = ws.by_dof_begin[k]; s < ws.by_dof_begin[k + 1]; ++s) {
        const int i = ws.by_dof_variable[s];
        if (i < j) continue;
        if (ws.marker[i] != j) {
          ws.marker[i] = j;
          ws.touched.push_back(i);
        }
        ws.accumulator[i] += ws.by_dof_value[s] * kv;
      }
    }
    std::sort(ws.touched.begin(), ws.touched.end());
    for (int i : ws.touched) {
      ws.a_row.push_back(i);
      ws.a_value.push_back(ws.accumulator[i]);
      ws.accumulator[i] = 0.0;
    }
    ws.a_begin.push_back(static_cast<int>(ws.a_row.size()));
  }
}

// y = A x + b from the lower triangle
void gradient(const ProjectedNewtonWorkspace& ws, const std::vector<double>& x,
              std::vector<double>& y) {
  const int n = static_cast<int>(x.size());
  std::copy(ws.b.begin(), ws.b.end(), y.begin());
  for (int j = 0; j < n; ++j)
    for (int e = ws.a_begin[j]; e < ws.a_begin[j + 1]; ++e) {
      const int i = ws.a_row[e];
      const double a = ws.a_value[e];
      y[i] += a * x[j];
      if (i != j) y[j] += a * x[i];
    }
}

// f = 1/2 x^T A x + b^T x from g = A x + b
double objective(const std::vector<double>& x, const std::vector<double>& g,
                 const std::vector<double>& b) {
  double f = 0.0;
  for (std::size_t i = 0; i < x.size(); ++i) f += 0.5 * x[i] * (g[i] + b[i]);
  return f;
}

// the variables of blocks on a bound that the gradient pushes outwards (eps: the margin)
void markBinding(const SeparableSet& set, const std::vector<double>& x,
                 const std::vector<double>& g, double eps, std::vector<char>& binding) {
  for (int b = 0; b < set.blocks(); ++b) {
    const int i = set.first[b];
    switch (effectiveSet(set, b)) {
      case BlockSet::Fixed:
        for (int k = 0; k < set.size[b]; ++k) binding[i + k] = 1;
        break;
      case BlockSet::Free:
        binding[i] = 0;
        break;
      case BlockSet::NonNegative:
        binding[i] = x[i] <= eps && g[i] > 0.0;
        break;
      case BlockSet::Ball: {
        const double r = set.radius[b];
        binding[i] = (x[i] >= r - eps && g[i] < 0.0) || (x[i] <= -r + eps && g[i] > 0.0);
        break;
      }
    }
  }
}

// the bounds of variable i's box (+-inf where open)
void boundsOf(const SeparableSet& set, int b, double& low, double& high) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  switch (effectiveSet(set, b)) {
    case BlockSet::Fixed:
      low = high = 0.0;
      return;
    case BlockSet::Free:
      low = -inf;
      high = inf;
      return;
    case BlockSet::NonNegative:
      low = 0.0;
      high = inf;
      return;
    case BlockSet::Ball:
      low = -set.radius[b];
      high = set.radius[b];
      return;
  }
}

// the reduced matrix: A + rho I on the free variables, the identity on the others
void reducedMatrix(ProjectedNewtonWorkspace& ws, int n, const std::vector<char>& fixed) {
  for (int j = 0; j < n; ++j)
    for (int e = ws.a_begin[j]; e < ws.a_begin[j + 1]; ++e) {
      const int i = ws.a_row[e];
      if (fixed[i] || fixed[j])
        ws.factor_value[e] = i == j ? 1.0 : 0.0;
      else
        ws.factor_value[e] = ws.a_value[e] + (i == j ? kRegularization : 0.0);
    }
}

}  // namespace

MprgpStats solveProjectedNewton(const QpOperator& op, const SeparableSet& set,
                                const MprgpSettings& settings, std::vector<double>& x, VectorX& v,
                                ProjectedNewtonWorkspace& ws, MprgpWorkspace& fallback) {
  const int n = set.variables;
  MprgpStats stats;
  x.resize(n);
  ws.J.clear();
  ws.K.clear();
  if (n == 0 || !op.columns(ws.J, ws.K) || ws.J.columns() != n || ws.K.columns() != n)
    return solveMprgp(op, set, settings, x, v, fallback);
  project(set, x);
  for (std::vector<double>* w : {&ws.b, &ws.g, &ws.d, &ws.x_trial, &ws.g_trial}) w->resize(n);
  ws.binding.resize(n);
  op.toGradient(v, true, ws.b);  // b: the gradient at x = 0
  stats.products = 1;
  formProduct(ws, n, static_cast<int>(v.size()));
  if (!ws.cholesky) ws.cholesky = std::make_unique<SparseCholesky>();
  ws.factor_value.resize(ws.a_value.size());
  bool usable = ws.cholesky->analyze(n, ws.a_begin, ws.a_row);

  gradient(ws, x, ws.g);
  const int newton_cap = std::min(kMaxNewton, settings.max_iterations);
  ws.lower.resize(n);
  ws.upper.resize(n);
  for (int b = 0; b < set.blocks(); ++b)
    for (int k = 0; k < set.size[b]; ++k)
      boundsOf(set, b, ws.lower[set.first[b] + k], ws.upper[set.first[b] + k]);
  ws.side.resize(n);
  ws.x_best = x;
  ws.x_start = x;
  // the warm start is not kept as it is: at least one step, as MPRGP takes one iteration
  double best = std::numeric_limits<double>::infinity();
  // sides from x and its gradient: held at the bound where x - g leaves the box
  auto sidesFrom = [&]() {
    for (int i = 0; i < n; ++i) {
      const double y = x[i] - ws.g[i];
      ws.side[i] = y <= ws.lower[i] ? kLower : y >= ws.upper[i] ? kUpper : kFree;
    }
  };
  // factorizes the matrix reduced to the variables not binding and solves for -g there
  auto newtonDirection = [&]() {
    reducedMatrix(ws, n, ws.binding);
    for (int i = 0; i < n; ++i) ws.g_trial[i] = ws.binding[i] ? 0.0 : -ws.g[i];
    ++stats.iterations;
    return ws.cholesky->factorize(ws.factor_value) && ws.cholesky->solve(ws.g_trial, ws.d);
  };
  auto keepIfBest = [&](const std::vector<double>& xp, const std::vector<double>& gp) {
    const double residual = naturalResidual(set, xp, gp);
    if (residual < best) {
      best = residual;
      ws.x_best = xp;
    }
  };

  // squared natural map |x - clamp(x - g)|^2, defined at infeasible x too
  auto merit = [&](const std::vector<double>& xp, const std::vector<double>& gp) {
    double sum = 0.0;
    for (int i = 0; i < n; ++i) {
      const double r = xp[i] - std::clamp(xp[i] - gp[i], ws.lower[i], ws.upper[i]);
      sum += r * r;
    }
    return sum;
  };
  // One semismooth Newton step on the natural map F(x) = x - P(x - g(x)) (the primal-dual
  // active set step of Hintermueller, Ito & Kunisch 2003, damped): sides from x - g, the
  // face's exact solution as the full step, halved until |F| falls by the Armijo factor.
  // Returns false, x back at the best point, when no step length lowers |F|.
  auto semismoothStep = [&]() {
    sidesFrom();
    ws.x_prev = x;
    ws.g_prev = ws.g;
    const double f0 = merit(x, ws.g);
    for (int i = 0; i < n; ++i) {
      ws.binding[i] = ws.side[i] != kFree;
      if (ws.side[i] == kLower) x[i] = ws.lower[i];
      if (ws.side[i] == kUpper) x[i] = ws.upper[i];
    }
    gradient(ws, x, ws.g);
    if (!newtonDirection()) return usable = false;
    for (int i = 0; i < n; ++i)
      if (!ws.binding[i]) x[i] += ws.d[i];
    gradient(ws, x, ws.g);
    // the full step, projected, may already be the answer (the line search's test cannot see
    // a decrease below round-off)
    ws.x_trial = x;
    project(set, ws.x_trial);
    gradient(ws, ws.x_trial, ws.g_trial);
    keepIfBest(ws.x_trial, ws.g_trial);
    if (best <= settings.tolerance) return true;
    double t = 1.0;
    for (int halving = 0; halving <= kMaxHalvings; ++halving, t *= 0.5) {
      for (int i = 0; i < n; ++i) {
        ws.x_trial[i] = ws.x_prev[i] + t * (x[i] - ws.x_prev[i]);
        ws.g_trial[i] = ws.g_prev[i] + t * (ws.g[i] - ws.g_prev[i]);
      }
      if (merit(ws.x_trial, ws.g_trial) <= (1.0 - kArmijo * t) * f0) {
        // copied, not swapped: x is the caller's, and a swap would hand it this workspace's
        // buffer, too small for the caller's next program
        std::copy(ws.x_trial.begin(), ws.x_trial.end(), x.begin());
        ws.g.swap(ws.g_trial);
        ws.x_trial = x;
        project(set, ws.x_trial);
        gradient(ws, ws.x_trial, ws.g_trial);
        keepIfBest(ws.x_trial, ws.g_trial);
        return true;
      }
    }
    x = ws.x_best;
    gradient(ws, x, ws.g);
    return false;
  };

  // One projected Newton step from the feasible x (Bertsekas 1982): the binding set (within
  // eps = min(1e-3, |x - P(x - g)|) of a bound, the gradient pointing out) takes a gradient
  // step, the others the Newton step, and a projected line search on f follows. Monotone in
  // f: where the damped semismooth step stalls, it still descends.
  auto projectedStep = [&]() {
    double w2 = 0.0;
    for (int i = 0; i < n; ++i) ws.x_trial[i] = x[i] - ws.g[i];
    project(set, ws.x_trial);
    for (int i = 0; i < n; ++i) w2 += (x[i] - ws.x_trial[i]) * (x[i] - ws.x_trial[i]);
    markBinding(set, x, ws.g, std::min(kBindingMargin, std::sqrt(w2)), ws.binding);
    if (!newtonDirection()) return usable = false;
    for (int i = 0; i < n; ++i)
      if (ws.binding[i]) ws.d[i] = -ws.g[i];
    const double f = objective(x, ws.g, ws.b);
    double alpha = 1.0;
    for (int halving = 0; halving <= kMaxHalvings; ++halving, alpha *= 0.5) {
      for (int i = 0; i < n; ++i) ws.x_trial[i] = x[i] + alpha * ws.d[i];
      project(set, ws.x_trial);
      double slope = 0.0;
      for (int i = 0; i < n; ++i) slope += ws.g[i] * (ws.x_trial[i] - x[i]);
      gradient(ws, ws.x_trial, ws.g_trial);
      if (slope <= 0.0 && objective(ws.x_trial, ws.g_trial, ws.b) <= f + kArmijo * slope) {
        std::copy(ws.x_trial.begin(), ws.x_trial.end(), x.begin());
        ws.g.swap(ws.g_trial);
        keepIfBest(x, ws.g);
        return true;
      }
    }
    return usable = false;  // no descent: no solution along the Newton direction
  };

  while (usable && stats.iterations < newton_cap && !(best <= settings.tolerance))
    if (!semismoothStep() && usable) projectedStep();
  x = ws.x_best;
  const bool converged = best <= settings.tolerance && stats.iterations > 0;
  stats.newton_steps = stats.iterations;

  // the answer, and its residual measured as MPRGP measures it (through the operator), in
  // z_trial so that a fallback starts from v as given
  fallback.prepare(n, static_cast<int>(v.size()));
  op.toVelocity(x, fallback.z);
  VectorX &z = fallback.z, &v_x = fallback.z_trial;
  const std::vector<int>* dofs = op.dofs();
  if (dofs != nullptr)
    for (int k : *dofs) v_x[k] = v[k] + z[k];
  else
    v_x = v + z;
  op.toGradient(v_x, true, ws.g);
  stats.products += 2;
  stats.residual = naturalResidual(set, x, ws.g);
  stats.converged = converged && stats.residual <= settings.tolerance;
  if (stats.converged) {
    if (dofs != nullptr)
      for (int k : *dofs) v[k] = v_x[k];
    else
      v = v_x;
    return stats;
  }

  // MPRGP from the warm start, as if the Newton steps had not been taken: where they fail, the
  // program may have no solution (a jammed packing pushed by a driven body), and their best
  // iterate then carries impulses grown along the unbounded direction, which MPRGP's own test
  // for that direction (mprgp.hpp) would meet only later
  x = ws.x_start;
  MprgpSettings rest = settings;
  rest.max_iterations = std::max(1, settings.max_iterations - stats.iterations);
  const MprgpStats finish = solveMprgp(op, set, rest, x, v, fallback);
  MprgpStats total = finish;
  total.iterations += stats.iterations;
  total.products += stats.products;
  total.newton_steps = stats.newton_steps;
  return total;
}

}  // namespace sweep
