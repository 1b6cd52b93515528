#include "integrators/projected_newton.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "framework/parallel.hpp"
#include "integrators/sparse_cholesky.hpp"

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
constexpr char kFree = 0, kLower = 1, kUpper = 2, kSlide = 3;

}  // namespace

ProjectedNewtonWorkspace::ProjectedNewtonWorkspace() = default;
ProjectedNewtonWorkspace::~ProjectedNewtonWorkspace() = default;
ProjectedNewtonWorkspace::ProjectedNewtonWorkspace(ProjectedNewtonWorkspace&&) noexcept = default;
ProjectedNewtonWorkspace& ProjectedNewtonWorkspace::operator=(ProjectedNewtonWorkspace&&) noexcept =
    default;
int ProjectedNewtonWorkspace::factorThreads() const {
  return cholesky ? cholesky->threads() : 1;
}

bool projectedNewtonApplies(const SeparableSet& set) {
  for (int b = 0; b < set.blocks(); ++b) {
    if (set.size[b] == 1) continue;
    const BlockSet kind = effectiveSet(set, b);
    if (set.size[b] != 2 || (kind != BlockSet::Fixed && kind != BlockSet::Ball)) return false;
  }
  return true;
}

namespace {

// f = 1/2 x^T A x + b^T x from g = A x + b
double objective(const std::vector<double>& x, const std::vector<double>& g,
                 ProjectedNewtonWorkspace& ws, int threads) {
  return sumInChunks(static_cast<long>(x.size()), threads, ws.sum_parts,
                     [&](long i, double& f) { f += 0.5 * x[i] * (g[i] + ws.b[i]); });
}

// the variables of blocks on a bound that the gradient pushes outwards (eps: the margin)
void markBinding(const SeparableSet& set, const std::vector<double>& x,
                 const std::vector<double>& g, double eps, std::vector<char>& binding,
                 int threads) {
  forEachIndex(set.blocks(), threads, [&](long b) {
    const int i = set.first[b];
    switch (effectiveSet(set, static_cast<int>(b))) {
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
        if (set.size[b] == 1) {
          binding[i] = (x[i] >= r - eps && g[i] < 0.0) || (x[i] <= -r + eps && g[i] > 0.0);
          break;
        }
        // a disc binds whole: on its circle, the gradient pointing out of it
        const bool out =
            std::hypot(x[i], x[i + 1]) >= r - eps && x[i] * g[i] + x[i + 1] * g[i + 1] < 0.0;
        binding[i] = binding[i + 1] = out;
        break;
      }
    }
  });
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

// the first variable of i's block and i's place in it
int blockFirst(const ProjectedNewtonWorkspace& ws, int i) {
  return ws.partner[i] >= 0 && ws.partner[i] < i ? ws.partner[i] : i;
}

// ws.block_entry: for each lower-triangle entry (i, j), the positions of A(first_i + a,
// first_j + c), a and c over the two blocks' variables (binary searches in the sorted columns)
void blockEntries(ProjectedNewtonWorkspace& ws, int n) {
  const auto position = [&](int row, int column) {
    if (row < column) std::swap(row, column);
    const auto begin = ws.a_row.begin() + ws.a_begin[column];
    const auto end = ws.a_row.begin() + ws.a_begin[column + 1];
    const auto it = std::lower_bound(begin, end, row);
    return it != end && *it == row ? static_cast<int>(it - ws.a_row.begin()) : -1;
  };
  ws.block_entry.assign(4 * ws.a_row.size(), -1);
  for (int j = 0; j < n; ++j) {
    const int fj = blockFirst(ws, j), sj = ws.partner[j] >= 0 ? 2 : 1;
    for (int e = ws.a_begin[j]; e < ws.a_begin[j + 1]; ++e) {
      const int i = ws.a_row[e];
      const int fi = blockFirst(ws, i), si = ws.partner[i] >= 0 ? 2 : 1;
      if (si == 1 && sj == 1) continue;
      for (int a = 0; a < si; ++a)
        for (int c = 0; c < sj; ++c) ws.block_entry[4 * e + 2 * a + c] = position(fi + a, fj + c);
    }
  }
}

// variable i's direction in its block's variables: (n, tau)'s column where the block is
// rotated, the unit vector otherwise
void directionOf(const ProjectedNewtonWorkspace& ws, int i, double* r) {
  const int f = blockFirst(ws, i);
  if (!ws.rotated[i]) {
    r[0] = i == f ? 1.0 : 0.0;
    r[1] = i == f ? 0.0 : 1.0;
  } else if (i == f) {  // n
    r[0] = ws.frame[f];
    r[1] = ws.frame[f + 1];
  } else {  // tau
    r[0] = -ws.frame[f + 1];
    r[1] = ws.frame[f];
  }
}

// entry (i, j) of R^T A R, R the block rotation of the sliding discs
double rotatedEntry(const ProjectedNewtonWorkspace& ws, int e, int i, int j) {
  double ri[2], rj[2];
  directionOf(ws, i, ri);
  directionOf(ws, j, rj);
  const int si = ws.partner[i] >= 0 ? 2 : 1, sj = ws.partner[j] >= 0 ? 2 : 1;
  double sum = 0.0;
  for (int a = 0; a < si; ++a)
    for (int c = 0; c < sj; ++c) {
      const int at = ws.block_entry[4 * e + 2 * a + c];
      if (at >= 0) sum += ri[a] * ws.a_value[at] * rj[c];
    }
  return sum;
}

// the reduced matrix: A + rho I on the free variables, the identity on the others; with
// `rotate`, in the frames of the sliding discs (ws.rotated), the circle's curvature on their
// tangents
void reducedMatrix(ProjectedNewtonWorkspace& ws, int n, const std::vector<char>& fixed, bool rotate,
                   int threads) {
  forEachIndex(n, threads, [&](long j) {
    for (int e = ws.a_begin[j]; e < ws.a_begin[j + 1]; ++e) {
      const int i = ws.a_row[e];
      if (fixed[i] || fixed[j]) {
        ws.factor_value[e] = i == j ? 1.0 : 0.0;
      } else if (rotate && (ws.rotated[i] || ws.rotated[j])) {
        ws.factor_value[e] = rotatedEntry(ws, e, i, static_cast<int>(j)) +
                             (i == j ? kRegularization + ws.curvature[i] : 0.0);
      } else {
        ws.factor_value[e] = ws.a_value[e] + (i == j ? kRegularization : 0.0);
      }
    }
  });
}

}  // namespace

namespace {

// One solve of solveProjectedNewton: the program, its workspace and the best point so far.
// The loops over the variables run on threads from kParallelItems variables on; their sums
// are taken in fixed chunks: the bits do not depend on the thread count.
class NewtonSolve {
 public:
  NewtonSolve(const QpOperator& op, const SeparableSet& set, const MprgpSettings& settings,
              std::vector<double>& x, ProjectedNewtonWorkspace& ws)
      : op_(op),
        set_(set),
        settings_(settings),
        x_(x),
        ws_(ws),
        n_(set.variables),
        threads_(settings.threads) {}

  // A formed and analysed, the bounds and the gradient at the warm start x; false when the
  // factorization cannot be used
  bool prepare(const VectorX& v) {
    const int n = n_;
    project(set_, x_);
    for (std::vector<double>* w : {&ws_.b, &ws_.g, &ws_.d, &ws_.x_trial, &ws_.g_trial})
      w->resize(n);
    ws_.binding.resize(n);
    op_.toGradient(v, true, ws_.b);  // b: the gradient at x = 0
    stats.products = 1;
    formDelassus(ws_, set_, static_cast<int>(v.size()));
    ws_.rotated.assign(n, 0);
    ws_.frame.assign(n, 0.0);
    ws_.curvature.assign(n, 0.0);
    has_discs_ = std::any_of(ws_.partner.begin(), ws_.partner.end(), [](int p) { return p >= 0; });
    if (has_discs_) blockEntries(ws_, n);
    if (!ws_.cholesky) ws_.cholesky = std::make_unique<SparseCholesky>();
    ws_.factor_value.resize(ws_.a_value.size());
    usable_ = ws_.cholesky->analyze(n, ws_.a_begin, ws_.a_row, threads_);
    // the chunked sums' parts, sized before the iterations
    const long chunks = (std::max(n, set_.blocks()) + kReduceChunk - 1) / kReduceChunk;
    ws_.sum_parts.reserve(chunks);
    ws_.residual_parts.reserve(chunks);
    delassusGradient(ws_, x_, ws_.g, threads_);
    ws_.lower.resize(n);
    ws_.upper.resize(n);
    for (int b = 0; b < set_.blocks(); ++b)
      for (int k = 0; k < set_.size[b]; ++k)
        boundsOf(set_, b, ws_.lower[set_.first[b] + k], ws_.upper[set_.first[b] + k]);
    ws_.side.resize(n);
    ws_.x_best = x_;
    ws_.x_start = x_;
    ws_.x_prev.resize(n);
    ws_.g_prev.resize(n);
    return usable_;
  }

  // Semismooth steps, and a projected step where one stalls, to the tolerance, the cap or a
  // failure; x is then the best point. Returns whether it met the tolerance.
  bool iterate() {
    const int newton_cap = std::min(kMaxNewton, settings_.max_iterations);
    while (usable_ && stats.iterations < newton_cap && !(best_ <= settings_.tolerance))
      if (!semismoothStep() && usable_) projectedStep();
    x_ = ws_.x_best;
    stats.newton_steps = stats.iterations;
    return best_ <= settings_.tolerance && stats.iterations > 0;
  }

  MprgpStats stats;

 private:
  template <class Body>
  void each(Body&& body) {
    forEachIndex(n_, threads_, body);
  }
  template <class Add>
  double sum(Add&& add) {
    return sumInChunks(n_, threads_, ws_.sum_parts, add);
  }
  void copy(const std::vector<double>& from, std::vector<double>& to) {
    each([&](long i) { to[i] = from[i]; });
  }

  // sides from x and its gradient: held at the bound where x - g leaves the box, strictly: a
  // row on its bound with zero gradient (a grain resting on one that falls as fast) stays free,
  // else a pile at rest closes one layer per step. A disc slides where x - g leaves its circle,
  // its unit normal y / |y| then in ws.frame
  void sidesFrom() {
    forEachIndex(set_.blocks(), threads_, [&](long b) {
      const int i = set_.first[b];
      if (set_.size[b] == 1 || effectiveSet(set_, static_cast<int>(b)) == BlockSet::Fixed) {
        for (int k = i; k < i + set_.size[b]; ++k) {
          const double y = x_[k] - ws_.g[k];
          const bool fixed = ws_.lower[k] == ws_.upper[k];
          ws_.side[k] = y < ws_.lower[k] || fixed ? kLower : y > ws_.upper[k] ? kUpper : kFree;
        }
        return;
      }
      const double y0 = x_[i] - ws_.g[i], y1 = x_[i + 1] - ws_.g[i + 1];
      const double norm = std::hypot(y0, y1);
      const bool slides = norm > set_.radius[b];
      ws_.side[i] = ws_.side[i + 1] = slides ? kSlide : kFree;
      if (slides) {
        ws_.frame[i] = y0 / norm;
        ws_.frame[i + 1] = y1 / norm;
      }
    });
  }
  // factorizes the matrix reduced to the variables not binding and solves for -g there, d = 0
  // on the binding ones; with `rotate`, a sliding disc's tangent is one of those variables, its
  // normal binding, and d comes back from the frame: d_b = tau u
  bool newtonDirection(bool rotate) {
    reducedMatrix(ws_, n_, ws_.binding, rotate, threads_);
    each([&](long i) {
      if (ws_.binding[i]) {
        ws_.g_trial[i] = 0.0;
      } else if (rotate && ws_.rotated[i]) {
        double r[2];
        directionOf(ws_, static_cast<int>(i), r);
        const int f = blockFirst(ws_, static_cast<int>(i));
        ws_.g_trial[i] = -(r[0] * ws_.g[f] + r[1] * ws_.g[f + 1]);
      } else {
        ws_.g_trial[i] = -ws_.g[i];
      }
    });
    ++stats.iterations;
    if (!ws_.cholesky->factorize(ws_.factor_value)) return false;
    ws_.cholesky->solve(ws_.g_trial, ws_.d);
    each([&](long i) {
      if (rotate && ws_.rotated[i]) {
        if (blockFirst(ws_, static_cast<int>(i)) == i) return;  // set by its tangent below
        const double u = ws_.d[i];
        ws_.d[i - 1] = -ws_.frame[i] * u;
        ws_.d[i] = ws_.frame[i - 1] * u;
      } else if (ws_.binding[i]) {
        ws_.d[i] = 0.0;
      }
    });
    return true;
  }
  void keepIfBest(const std::vector<double>& xp, const std::vector<double>& gp) {
    const double residual = naturalResidual(set_, xp, gp, threads_, ws_.residual_parts);
    if (residual < best_) {
      best_ = residual;
      copy(xp, ws_.x_best);
    }
  }
  // squared natural map |x - P(x - g)|^2, defined at infeasible x too; summed by blocks (in
  // chunks: the same bits for every thread count)
  double merit(const std::vector<double>& xp, const std::vector<double>& gp) {
    return sumInChunks(set_.blocks(), threads_, ws_.sum_parts, [&](long b, double& part) {
      const int i = set_.first[b];
      if (set_.size[b] == 1) {
        const double r = xp[i] - std::clamp(xp[i] - gp[i], ws_.lower[i], ws_.upper[i]);
        part += r * r;
        return;
      }
      double y[2] = {xp[i] - gp[i], xp[i + 1] - gp[i + 1]};
      projectBlock(set_, static_cast<int>(b), y);
      part += (xp[i] - y[0]) * (xp[i] - y[0]) + (xp[i + 1] - y[1]) * (xp[i + 1] - y[1]);
    });
  }
  // the projection of x_trial, its gradient, and the best point kept
  void keepProjectedTrial() {
    project(set_, ws_.x_trial, threads_);
    delassusGradient(ws_, ws_.x_trial, ws_.g_trial, threads_);
    keepIfBest(ws_.x_trial, ws_.g_trial);
  }

  // The curvature of each sliding disc's circle in the Lagrangian's Hessian, lambda / r on its
  // tangent, lambda = max(0, -n . g) the multiplier that holds the disc on the circle
  void sideCurvatures() {
    each([&](long i) {
      const int f = blockFirst(ws_, static_cast<int>(i));
      if (!ws_.rotated[i] || f == i) return;
      const double push = -(ws_.frame[f] * ws_.g[f] + ws_.frame[i] * ws_.g[i]);
      ws_.curvature[i] = std::max(push, 0.0) / ws_.upper[i];
    });
  }

  // One semismooth Newton step on the natural map F(x) = x - P(x - g(x)) (the primal-dual
  // active set step of Hintermueller, Ito & Kunisch 2003, damped): sides from x - g, the
  // face's exact solution as the full step, halved until |F| falls by the Armijo factor.
  // Returns false, x back at the best point, when no step length lowers |F|.
  bool semismoothStep() {
    std::vector<double>& x = x_;
    sidesFrom();
    copy(x, ws_.x_prev);
    copy(ws_.g, ws_.g_prev);
    const double f0 = merit(x, ws_.g);
    each([&](long i) {
      ws_.binding[i] = ws_.side[i] != kFree;
      ws_.rotated[i] = ws_.side[i] == kSlide;
      if (ws_.side[i] == kLower) x[i] = ws_.lower[i];
      if (ws_.side[i] == kUpper) x[i] = ws_.upper[i];
      if (ws_.side[i] == kSlide) {  // on the circle at the normal; the tangent stays free
        x[i] = ws_.upper[i] * ws_.frame[i];
        ws_.binding[i] = blockFirst(ws_, static_cast<int>(i)) == i;
      }
    });
    delassusGradient(ws_, x, ws_.g, threads_);
    if (has_discs_) sideCurvatures();
    if (!newtonDirection(true)) return usable_ = false;
    each([&](long i) { x[i] += ws_.d[i]; });
    delassusGradient(ws_, x, ws_.g, threads_);
    // the full step, projected, may already be the answer (the line search's test cannot see
    // a decrease below round-off)
    copy(x, ws_.x_trial);
    keepProjectedTrial();
    if (best_ <= settings_.tolerance) return true;
    double t = 1.0;
    for (int halving = 0; halving <= kMaxHalvings; ++halving, t *= 0.5) {
      each([&](long i) {
        ws_.x_trial[i] = ws_.x_prev[i] + t * (x[i] - ws_.x_prev[i]);
        ws_.g_trial[i] = ws_.g_prev[i] + t * (ws_.g[i] - ws_.g_prev[i]);
      });
      if (merit(ws_.x_trial, ws_.g_trial) <= (1.0 - kArmijo * t) * f0) {
        // copied, not swapped: x is the caller's, and a swap would hand it this workspace's
        // buffer, too small for the caller's next program
        copy(ws_.x_trial, x);
        ws_.g.swap(ws_.g_trial);
        copy(x, ws_.x_trial);
        keepProjectedTrial();
        return true;
      }
    }
    copy(ws_.x_best, x);
    delassusGradient(ws_, x, ws_.g, threads_);
    return false;
  }

  // One projected Newton step from the feasible x (Bertsekas 1982): the binding set (within
  // eps = min(1e-3, |x - P(x - g)|) of a bound, the gradient pointing out) takes a gradient
  // step, the others the Newton step, and a projected line search on f follows. Monotone in
  // f: where the damped semismooth step stalls, it still descends.
  bool projectedStep() {
    std::vector<double>& x = x_;
    each([&](long i) { ws_.x_trial[i] = x[i] - ws_.g[i]; });
    project(set_, ws_.x_trial, threads_);
    const double w2 = sum(
        [&](long i, double& part) { part += (x[i] - ws_.x_trial[i]) * (x[i] - ws_.x_trial[i]); });
    markBinding(set_, x, ws_.g, std::min(kBindingMargin, std::sqrt(w2)), ws_.binding, threads_);
    if (!newtonDirection(false)) return usable_ = false;
    each([&](long i) {
      if (ws_.binding[i]) ws_.d[i] = -ws_.g[i];
    });
    const double f = objective(x, ws_.g, ws_, threads_);
    double alpha = 1.0;
    for (int halving = 0; halving <= kMaxHalvings; ++halving, alpha *= 0.5) {
      each([&](long i) { ws_.x_trial[i] = x[i] + alpha * ws_.d[i]; });
      project(set_, ws_.x_trial, threads_);
      const double slope =
          sum([&](long i, double& part) { part += ws_.g[i] * (ws_.x_trial[i] - x[i]); });
      delassusGradient(ws_, ws_.x_trial, ws_.g_trial, threads_);
      if (slope <= 0.0 &&
          objective(ws_.x_trial, ws_.g_trial, ws_, threads_) <= f + kArmijo * slope) {
        copy(ws_.x_trial, x);
        ws_.g.swap(ws_.g_trial);
        keepIfBest(x, ws_.g);
        return true;
      }
    }
    return usable_ = false;  // no descent: no solution along the Newton direction
  }

  const QpOperator& op_;
  const SeparableSet& set_;
  const MprgpSettings& settings_;
  std::vector<double>& x_;
  ProjectedNewtonWorkspace& ws_;
  int n_;
  int threads_;
  bool usable_ = true;
  bool has_discs_ = false;
  // the warm start is not kept as it is: at least one step, as MPRGP takes one iteration
  double best_ = std::numeric_limits<double>::infinity();
};

}  // namespace

MprgpStats solveProjectedNewton(const QpOperator& op, const SeparableSet& set,
                                const MprgpSettings& settings, std::vector<double>& x, VectorX& v,
                                ProjectedNewtonWorkspace& ws, MprgpWorkspace& fallback) {
  const int n = set.variables;
  x.resize(n);
  ws.J.clear();
  ws.K.clear();
  if (n == 0 || !op.columns(ws.J, ws.K) || ws.J.columns() != n || ws.K.columns() != n)
    return solveSeparableQp(op, set, settings, x, v, fallback);
  NewtonSolve solve(op, set, settings, x, ws);
  solve.prepare(v);
  const bool converged = solve.iterate();
  MprgpStats stats = solve.stats;

  if (acceptDirectAnswer(op, set, settings, x, converged, v, ws.g, fallback, stats)) return stats;

  // MPRGP from the warm start, as if the Newton steps had not been taken: where they fail, the
  // program may have no solution (a jammed packing pushed by a driven body), and their best
  // iterate then carries impulses grown along the unbounded direction, which MPRGP's own test
  // for that direction (mprgp.hpp) would meet only later
  x = ws.x_start;
  MprgpSettings rest = settings;
  rest.max_iterations = std::max(1, settings.max_iterations - stats.iterations);
  const MprgpStats finish = solveSeparableQp(op, set, rest, x, v, fallback);
  MprgpStats total = finish;
  total.iterations += stats.iterations;
  total.products += stats.products;
  total.newton_steps = stats.newton_steps;
  return total;
}

}  // namespace sweep
