#include "integrators/mprgp.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "framework/parallel.hpp"

namespace sweep {

// the solvers' sums in chunks of this many items: a stage of 8 500 variables in 9 parts, where
// kReduceChunk's 3 would split 2 : 1 over two threads
constexpr long kSolverChunk = 1024;

void SeparableSet::clear() {
  first.clear();
  size.clear();
  set.clear();
  radius.clear();
  scale2.clear();
  variables = 0;
}

int SeparableSet::add(BlockSet block_set, int block_size, double block_radius,
                      double block_scale2) {
  const int begin = variables;
  first.push_back(begin);
  size.push_back(static_cast<std::uint8_t>(block_size));
  set.push_back(block_set);
  radius.push_back(block_radius);
  scale2.push_back(block_scale2);
  variables += block_size;
  return begin;
}

void clearVelocities(const std::vector<int>* dofs, VectorX& z, int threads) {
  if (dofs == nullptr) {
    z.setZero();
    return;
  }
  forEachIndex(static_cast<int>(dofs->size()), threads, [&](int k) { z[(*dofs)[k]] = 0.0; });
}

void MprgpWorkspace::prepare(int variables, int velocities) {
  for (std::vector<double>* w : {&g, &p, &Ap, &phi, &beta, &x_half, &g_half, &x_trial, &g_trial})
    w->resize(variables);
  sums.reserve(static_cast<std::size_t>(variables / kSolverChunk + 1));
  if (z.size() != velocities) {
    z.resize(velocities);
    z_trial.resize(velocities);
  }
}

void project(const SeparableSet& s, std::vector<double>& x, int threads) {
  forEachIndex(s.blocks(), threads, [&](int b) { projectBlock(s, b, x.data() + s.first[b]); });
}

namespace {

// The solvers' loops: items on threads from kParallelItems on, sums in fixed chunks.
struct Loops {
  int threads;
  std::vector<ChunkSums>& parts;

  template <class Body>
  void each(int n, Body&& body) const {
    forEachIndex(n, threads, body);
  }
  // add(i, sums) over [0, n), the sums starting from zero
  template <class Add>
  ChunkSums sum(int n, Add&& add) const {
    return reduceInChunks(
        static_cast<long>(n), threads, ChunkSums{}, parts,
        [&](long i, ChunkSums& part) { add(static_cast<int>(i), part); },
        [](ChunkSums& total, const ChunkSums& part) {
          for (int k = 0; k < 4; ++k) total[k] += part[k];
        },
        kSolverChunk);
  }
  double dot(const std::vector<double>& a, const std::vector<double>& b) const {
    return sum(static_cast<int>(a.size()), [&](int i, ChunkSums& s) { s[0] += a[i] * b[i]; })[0];
  }
  // v += a z over dofs (all when null)
  void addScaled(const std::vector<int>* dofs, double a, const VectorX& z, VectorX& v) const {
    if (dofs == nullptr) {
      each(static_cast<int>(v.size()), [&](int i) { v[i] += a * z[i]; });
      return;
    }
    each(static_cast<int>(dofs->size()), [&](int k) {
      const int i = (*dofs)[k];
      v[i] += a * z[i];
    });
  }
};

// a disc block this close to its radius (relative) is on the boundary: projections put it
// there only up to round-off
constexpr double kOnBoundary = 1e-12;
// curvature p^T A p / p^T p below this fraction of the largest seen: a direction in the
// numerical null space of A
constexpr double kFlat = 1e-9;

// phi: g on the blocks inside their set; beta: on the blocks on their boundary, the part of g
// that does not point out of the set. Also the natural-map residual at (x, g) (see
// naturalResidual), from the same classification of each block: one pass where the iteration
// would otherwise take two.
struct Split {
  double phi2 = 0.0, beta2 = 0.0, residual = 0.0;
};
// Block b's part of split(): phi and beta written, |phi|^2, |beta|^2 and the residual's two sums
// added to sums[0..3].
void splitBlock(const SeparableSet& s, int b, const double* x, const double* g, double* phi,
                double* beta, ChunkSums& sums) {
  double &phi2 = sums[0], &beta2 = sums[1], &f2 = sums[2], &scale2 = sums[3];
  const int f = s.first[b];
  const double r = s.radius[b];
  switch (s.set[b]) {
    case BlockSet::Fixed:
      phi[f] = beta[f] = 0.0;
      if (s.size[b] == 2) phi[f + 1] = beta[f + 1] = 0.0;
      return;
    case BlockSet::Free:
      phi[f] = g[f];
      beta[f] = 0.0;
      phi2 += g[f] * g[f];
      f2 += g[f] * g[f];
      scale2 += std::max(x[f] * x[f], g[f] * g[f]) + s.scale2[b];
      if (s.size[b] == 2) {
        phi[f + 1] = g[f + 1];
        beta[f + 1] = 0.0;
        phi2 += g[f + 1] * g[f + 1];
        f2 += g[f + 1] * g[f + 1];
        scale2 += std::max(x[f + 1] * x[f + 1], g[f + 1] * g[f + 1]);
      }
      return;
    case BlockSet::NonNegative: {
      const double F = x[f] - std::max(x[f] - g[f], 0.0);
      f2 += F * F;
      scale2 += std::max(x[f] * x[f], g[f] * g[f]) + s.scale2[b];
      if (x[f] > 0.0) {
        phi[f] = g[f];
        beta[f] = 0.0;
        phi2 += g[f] * g[f];
      } else {
        phi[f] = 0.0;
        beta[f] = std::min(g[f], 0.0);
        beta2 += beta[f] * beta[f];
      }
      return;
    }
    case BlockSet::Ball:
      break;
  }
  if (!(r > 0.0)) {  // a ball of radius zero is fixed
    phi[f] = beta[f] = 0.0;
    if (s.size[b] == 2) phi[f + 1] = beta[f + 1] = 0.0;
    return;
  }
  if (s.size[b] == 1) {
    const double F = x[f] - std::clamp(x[f] - g[f], -r, r);
    f2 += F * F;
    scale2 += std::max(x[f] * x[f], g[f] * g[f]) + s.scale2[b];
    if (std::abs(x[f]) < r) {
      phi[f] = g[f];
      beta[f] = 0.0;
      phi2 += g[f] * g[f];
    } else {
      phi[f] = 0.0;
      beta[f] = x[f] > 0.0 ? std::max(g[f], 0.0) : std::min(g[f], 0.0);
      beta2 += beta[f] * beta[f];
    }
    return;
  }
  double y[2] = {x[f] - g[f], x[f + 1] - g[f + 1]};
  const double y2 = y[0] * y[0] + y[1] * y[1];
  if (y2 > r * r) {
    const double shrink = r / std::sqrt(y2);
    y[0] *= shrink;
    y[1] *= shrink;
  }
  f2 += (x[f] - y[0]) * (x[f] - y[0]) + (x[f + 1] - y[1]) * (x[f + 1] - y[1]);
  const double norm2 = x[f] * x[f] + x[f + 1] * x[f + 1];
  scale2 += std::max(norm2, g[f] * g[f] + g[f + 1] * g[f + 1]) + s.scale2[b];
  if (norm2 < r * r * (1.0 - kOnBoundary)) {
    phi[f] = g[f];
    phi[f + 1] = g[f + 1];
    beta[f] = beta[f + 1] = 0.0;
    phi2 += g[f] * g[f] + g[f + 1] * g[f + 1];
    return;
  }
  const double norm = std::sqrt(norm2);
  const double nx = x[f] / norm, ny = x[f + 1] / norm;
  const double outward = std::min(g[f] * nx + g[f + 1] * ny, 0.0);
  phi[f] = phi[f + 1] = 0.0;
  beta[f] = g[f] - outward * nx;
  beta[f + 1] = g[f + 1] - outward * ny;
  beta2 += beta[f] * beta[f] + beta[f + 1] * beta[f + 1];
}

Split split(const SeparableSet& s, const std::vector<double>& x, const std::vector<double>& g,
            std::vector<double>& phi, std::vector<double>& beta, const Loops& loops) {
  const ChunkSums sums = loops.sum(s.blocks(), [&](int b, ChunkSums& part) {
    splitBlock(s, b, x.data(), g.data(), phi.data(), beta.data(), part);
  });
  Split out;
  out.phi2 = sums[0];
  out.beta2 = sums[1];
  out.residual = sums[3] > 0.0 ? std::sqrt(sums[2] / sums[3]) : std::sqrt(sums[2]);
  return out;
}

// the largest alpha >= 0 with x_b - alpha p_b in block b's set (infinite: no limit)
double blockStep(const SeparableSet& s, int b, const std::vector<double>& x,
                 const std::vector<double>& p) {
  constexpr double kNone = std::numeric_limits<double>::infinity();
  const int f = s.first[b];
  switch (effectiveSet(s, b)) {
    case BlockSet::Fixed:
    case BlockSet::Free:
      return kNone;
    case BlockSet::NonNegative:
      return p[f] > 0.0 ? std::max(x[f], 0.0) / p[f] : kNone;
    case BlockSet::Ball: {
      const double r = s.radius[b];
      if (s.size[b] == 1) {
        if (p[f] > 0.0) return std::max(x[f] + r, 0.0) / p[f];
        if (p[f] < 0.0) return std::min(x[f] - r, 0.0) / p[f];
        return kNone;
      }
      const double a = p[f] * p[f] + p[f + 1] * p[f + 1];
      if (!(a > 0.0)) return kNone;
      const double xp = x[f] * p[f] + x[f + 1] * p[f + 1];
      const double c = std::min(x[f] * x[f] + x[f + 1] * x[f + 1] - r * r, 0.0);
      return (xp + std::sqrt(xp * xp - a * c)) / a;
    }
  }
  return kNone;
}

// the largest alpha >= 0 with x - alpha p in the set: a minimum, exact in any order
double maxFeasibleStep(const SeparableSet& s, const std::vector<double>& x,
                       const std::vector<double>& p, const Loops& loops) {
  constexpr double kNone = std::numeric_limits<double>::infinity();
  const ChunkSums least = reduceInChunks(
      static_cast<long>(s.blocks()), loops.threads, ChunkSums{kNone, 0.0, 0.0, 0.0}, loops.parts,
      [&](long b, ChunkSums& part) {
        part[0] = std::min(part[0], blockStep(s, static_cast<int>(b), x, p));
      },
      [](ChunkSums& total, const ChunkSums& part) { total[0] = std::min(total[0], part[0]); },
      kSolverChunk);
  return least[0];
}

bool anyNonZero(const std::vector<double>& x) {
  for (double value : x)
    if (value != 0.0) return true;
  return false;
}

}  // namespace

void addResidualTerms(const SeparableSet& s, int b, const std::vector<double>& x,
                      const std::vector<double>& g, double& f2, double& scale2) {
  if (effectiveSet(s, b) == BlockSet::Fixed) return;
  const int f = s.first[b], n = s.size[b];
  double y[2] = {0.0, 0.0};
  double x2 = 0.0, g2 = 0.0;
  for (int i = 0; i < n; ++i) {
    y[i] = x[f + i] - g[f + i];
    x2 += x[f + i] * x[f + i];
    g2 += g[f + i] * g[f + i];
  }
  projectBlock(s, b, y);
  for (int i = 0; i < n; ++i) f2 += (x[f + i] - y[i]) * (x[f + i] - y[i]);
  scale2 += std::max(x2, g2) + s.scale2[b];
}

double naturalResidual(const SeparableSet& s, const std::vector<double>& x,
                       const std::vector<double>& g) {
  double f2 = 0.0, scale2 = 0.0;
  for (int b = 0; b < s.blocks(); ++b) addResidualTerms(s, b, x, g, f2, scale2);
  return scale2 > 0.0 ? std::sqrt(f2 / scale2) : std::sqrt(f2);
}

double naturalResidual(const SeparableSet& s, const std::vector<double>& x,
                       const std::vector<double>& g, int threads, std::vector<ChunkSums>& parts) {
  const Loops loops{threads, parts};
  const ChunkSums sums = loops.sum(
      s.blocks(), [&](int b, ChunkSums& part) { addResidualTerms(s, b, x, g, part[0], part[1]); });
  return sums[1] > 0.0 ? std::sqrt(sums[0] / sums[1]) : std::sqrt(sums[0]);
}

namespace {
// A d: z = M^-1 H E d (z's slot overwritten), then Ad = E^T H^T z; one product counted
void linearProduct(const QpOperator& op, const std::vector<double>& d, VectorX& z,
                   std::vector<double>& Ad, MprgpStats& stats) {
  op.toVelocity(d, z);
  op.toGradient(z, false, Ad);
  ++stats.products;
}

// Both solvers' start: the workspace sized, the warm start x projected onto the set and
// applied to v, and the gradient at it in ws.g (one product).
void start(const QpOperator& op, const SeparableSet& set, std::vector<double>& x, VectorX& v,
           MprgpWorkspace& ws, const Loops& loops, MprgpStats& stats) {
  x.resize(set.variables);
  ws.prepare(set.variables, static_cast<int>(v.size()));
  project(set, x, loops.threads);
  if (anyNonZero(x)) {
    op.toVelocity(x, ws.z);
    loops.addScaled(op.dofs(), 1.0, ws.z, v);
  }
  op.toGradient(v, true, ws.g);
  stats.products = 1;
}
}  // namespace

MprgpStats solveMprgp(const QpOperator& op, const SeparableSet& set, const MprgpSettings& settings,
                      std::vector<double>& x, VectorX& v, MprgpWorkspace& ws) {
  MprgpStats stats;
  const int n = set.variables;
  const Loops loops{settings.threads, ws.sums};
  start(op, set, x, v, ws, loops, stats);
  std::vector<double>&g = ws.g, &p = ws.p, &Ap = ws.Ap, &phi = ws.phi, &beta = ws.beta;
  Split at = split(set, x, g, phi, beta, loops);  // at x
  p = phi;
  double rayleigh = 1.0;  // largest p^T A p / p^T p seen (the scaled diagonal is about 1)
  double alpha_bar = 1.9 / rayleigh;
  const double gamma2 = settings.gamma * settings.gamma;

  // x_trial = P(from - step * direction) when it lowers f against (from, g_from); otherwise the
  // step is halved until it does (an expansion's alpha_bar with it, for the steps after).
  // Leaves x, g, v at the new point. The change of f is g_from^T dx + 1/2 dx^T A dx with A dx
  // from a linear product: a difference of gradients evaluated from v would cancel digits.
  auto projectedStep = [&](const std::vector<double>& from, const std::vector<double>& g_from,
                           const std::vector<double>& direction, double step, bool expansion) {
    for (int attempt = 0;; ++attempt) {
      loops.each(n, [&](int i) { ws.x_trial[i] = from[i] - step * direction[i]; });
      project(set, ws.x_trial, loops.threads);
      // dx, in x_trial's slot until x_trial is rebuilt as from + dx
      loops.each(n, [&](int i) { ws.x_trial[i] -= from[i]; });
      linearProduct(op, ws.x_trial, ws.z_trial, ws.g_trial, stats);
      const ChunkSums change = loops.sum(n, [&](int i, ChunkSums& part) {
        part[0] += g_from[i] * ws.x_trial[i];
        part[1] += ws.x_trial[i] * ws.g_trial[i];
      });
      const double linear = change[0], curvature = change[1];
      if (linear + 0.5 * curvature <= 0.0 || attempt >= 60) {
        loops.each(n, [&](int i) {
          ws.x_trial[i] += from[i];
          ws.g_trial[i] += g_from[i];
        });
        x.swap(ws.x_trial);
        g.swap(ws.g_trial);
        loops.addScaled(op.dofs(), 1.0, ws.z_trial, v);
        return;
      }
      step *= 0.5;
      if (expansion) alpha_bar = step;
    }
  };

  for (int it = 0;; ++it) {
    stats.residual = at.residual;
    // at least one iteration from a warm start, as a Gauss-Seidel solve takes one sweep: the
    // warm start's error, below the tolerance, would otherwise stay in every step of a body at
    // rest and add up (a block sticking on an incline crept 2.7e-6 m in 10^6 steps)
    const bool exact = at.phi2 == 0.0 && at.beta2 == 0.0;
    if (stats.residual < settings.tolerance && (it > 0 || exact)) {
      stats.converged = !stats.inconsistent;
      break;
    }
    if (it == settings.max_iterations) break;
    stats.iterations = it + 1;
    if (at.beta2 <= gamma2 * at.phi2) {
      linearProduct(op, p, ws.z, Ap, stats);
      const double pAp = loops.dot(p, Ap), pp = loops.dot(p, p);
      if (pp > 0.0 && pAp > 0.0 && pAp > rayleigh * pp) {
        rayleigh = pAp / pp;
        alpha_bar = std::min(alpha_bar, 1.9 / rayleigh);
      }
      // A direction of (numerically) no curvature: on a consistent program the gradient has no
      // part along it, on an inconsistent one (no velocity meets every constraint: a driven
      // body pushing into a jammed packing) the line search would run off to a huge impulse
      // that round-off turns into huge velocities. No CG step along it: the bounded projected
      // step of the expansion instead.
      const bool flat = !(pAp > kFlat * rayleigh * pp);
      // f falls without bound along a flat direction the gradient has a part along: the
      // program has no solution. The solve goes on with bounded steps (as Gauss-Seidel's
      // sweeps do) and is reported unconverged, whatever its relative residual, which a
      // growing impulse drives down.
      if (flat && std::abs(loops.dot(g, p)) > 1e-6 * std::sqrt(loops.dot(g, g) * pp))
        stats.inconsistent = true;
      const double feasible = flat ? 0.0 : maxFeasibleStep(set, x, p, loops);
      const double cg = flat ? std::numeric_limits<double>::infinity() : loops.dot(g, p) / pAp;
      if (cg <= feasible) {
        loops.each(n, [&](int i) {
          x[i] -= cg * p[i];
          g[i] -= cg * Ap[i];
        });
        loops.addScaled(op.dofs(), -cg, ws.z, v);
        at = split(set, x, g, phi, beta, loops);
        const double conjugate = loops.dot(phi, Ap) / pAp;
        loops.each(n, [&](int i) { p[i] = phi[i] - conjugate * p[i]; });
        ++stats.cg_steps;
        continue;
      }
      // expansion: the largest feasible step, then a projected free-gradient step
      const double step = std::isfinite(feasible) ? feasible : 0.0;
      loops.each(n, [&](int i) {
        ws.x_half[i] = x[i] - step * p[i];
        ws.g_half[i] = g[i] - step * Ap[i];
      });
      project(set, ws.x_half, loops.threads);
      loops.addScaled(op.dofs(), -step, ws.z, v);
      split(set, ws.x_half, ws.g_half, phi, beta, loops);
      projectedStep(ws.x_half, ws.g_half, phi, alpha_bar, true);
      ++stats.expansions;
    } else {
      // proportioning: exact line search along -beta, projected
      linearProduct(op, beta, ws.z, Ap, stats);
      const double bAb = loops.dot(beta, Ap);
      const double step = bAb > kFlat * rayleigh * at.beta2 ? loops.dot(g, beta) / bAb : alpha_bar;
      ws.x_half = x;
      ws.g_half = g;
      projectedStep(ws.x_half, ws.g_half, beta, step, false);
      ++stats.proportionings;
    }
    at = split(set, x, g, phi, beta, loops);
    p = phi;
  }
  return stats;
}

MprgpStats solveApgd(const QpOperator& op, const SeparableSet& set, const MprgpSettings& settings,
                     std::vector<double>& x, VectorX& v, MprgpWorkspace& ws) {
  MprgpStats stats;
  const int n = set.variables;
  const Loops loops{settings.threads, ws.sums};
  start(op, set, x, v, ws, loops, stats);
  // x, g, v: the iterate; y (x_half), g_y (g_half), v_y (z_trial): the extrapolated point
  std::vector<double>&g = ws.g, &y = ws.x_half, &g_y = ws.g_half, &d = ws.p, &Ad = ws.Ap;
  VectorX& v_y = ws.z_trial;
  y = x;
  g_y = g;
  v_y = v;
  double L = 1.0;  // Lipschitz constant of the gradient: about 1 for a unit diagonal
  double t = 1.0;
  for (int it = 0;; ++it) {
    stats.residual = naturalResidual(set, x, g, loops.threads, ws.sums);
    if (stats.residual < settings.tolerance && (it > 0 || stats.residual == 0.0)) {  // as MPRGP
      stats.converged = true;
      break;
    }
    if (it == settings.max_iterations) break;
    stats.iterations = it + 1;
    // d = P(y - g_y / L) - y, with L raised until the quadratic model majorizes f
    double dAd = 0.0, dd = 0.0;
    for (int attempt = 0;; ++attempt) {
      loops.each(n, [&](int i) { d[i] = y[i] - g_y[i] / L; });
      project(set, d, loops.threads);
      loops.each(n, [&](int i) { d[i] -= y[i]; });
      linearProduct(op, d, ws.z, Ad, stats);
      const ChunkSums curvature = loops.sum(n, [&](int i, ChunkSums& part) {
        part[0] += d[i] * Ad[i];
        part[1] += d[i] * d[i];
      });
      dAd = curvature[0];
      dd = curvature[1];
      if (dAd <= L * dd * (1.0 + 1e-12) || attempt >= 60) break;
      L = std::max(2.0 * L, dAd / dd);
    }
    // x_new = y + d; restart the momentum when it points uphill (O'Donoghue & Candes 2015)
    const double uphill =
        loops.sum(n, [&](int i, ChunkSums& part) { part[0] += g_y[i] * (y[i] + d[i] - x[i]); })[0];
    const bool restart = uphill > 0.0;
    const double t_next = restart ? 1.0 : 0.5 * (1.0 + std::sqrt(1.0 + 4.0 * t * t));
    const double momentum = restart ? 0.0 : (t - 1.0) / t_next;
    t = t_next;
    loops.each(n, [&](int i) {
      const double x_new = y[i] + d[i], g_new = g_y[i] + Ad[i];
      y[i] = x_new + momentum * (x_new - x[i]);
      g_y[i] = g_new + momentum * (g_new - g[i]);
      x[i] = x_new;
      g[i] = g_new;
    });
    // v_y + z is v at y + d = x_new; then v_y = v_new + momentum (v_new - v) and v = v_new
    const auto extrapolate = [&](int i) {
      const double v_new = v_y[i] + ws.z[i];
      v_y[i] = v_new + momentum * (v_new - v[i]);
      v[i] = v_new;
    };
    if (const std::vector<int>* dofs = op.dofs()) {
      loops.each(static_cast<int>(dofs->size()), [&](int k) { extrapolate((*dofs)[k]); });
    } else {
      loops.each(static_cast<int>(v.size()), extrapolate);
    }
    L *= 0.9;  // let the step grow back where the operator is milder
    ++stats.cg_steps;
  }
  return stats;
}

MprgpStats solveSeparableQp(const QpOperator& op, const SeparableSet& set,
                            const MprgpSettings& settings, std::vector<double>& x, VectorX& v,
                            MprgpWorkspace& ws) {
  for (int b = 0; b < set.blocks(); ++b)
    if (set.size[b] == 2 && effectiveSet(set, b) == BlockSet::Ball)
      return solveApgd(op, set, settings, x, v, ws);
  return solveMprgp(op, set, settings, x, v, ws);
}

}  // namespace sweep
