#include "integrators/event_driven.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "framework/crba.hpp"
#include "framework/dynamics.hpp"
#include "framework/error.hpp"

namespace sweep {

bool solveSmallLcp(const MatrixX& G, const VectorX& b, VectorX& x, double tolerance) {
  const int n = static_cast<int>(b.size());
  if (n > 12) throw std::invalid_argument("solveSmallLcp: more than 12 unknowns");
  x = VectorX::Zero(n);
  const double scale = std::max(b.cwiseAbs().maxCoeff(), std::numeric_limits<double>::min());
  const double tol = tolerance * scale;
  // subsets by increasing size, so that the sparsest solution wins when impulses are not
  // unique (redundant constraints)
  for (int size = 0; size <= n; ++size) {
    for (unsigned mask = 0; mask < (1u << n); ++mask) {
      if (__builtin_popcount(mask) != size) continue;
      std::vector<int> active;
      for (int i = 0; i < n; ++i)
        if (mask & (1u << i)) active.push_back(i);
      VectorX candidate = VectorX::Zero(n);
      if (size > 0) {
        MatrixX Gaa(size, size);
        VectorX ba(size);
        for (int r = 0; r < size; ++r) {
          ba[r] = b[active[r]];
          for (int c = 0; c < size; ++c) Gaa(r, c) = G(active[r], active[c]);
        }
        const VectorX xa = Gaa.completeOrthogonalDecomposition().solve(-ba);
        if ((Gaa * xa + ba).cwiseAbs().maxCoeff() > tol) continue;  // singular, inconsistent
        for (int r = 0; r < size; ++r) candidate[active[r]] = xa[r];
      }
      const VectorX w = G * candidate + b;
      bool ok = true;
      for (int i = 0; i < n && ok; ++i) ok = candidate[i] >= -tol && w[i] >= -tol;
      if (ok) {
        x = candidate.cwiseMax(0.0);
        return true;
      }
    }
  }
  return false;
}

EventDrivenReference::EventDrivenReference(const Model& model,
                                           std::vector<UnilateralConstraint> constraints,
                                           EventDrivenSettings settings)
    : model_(model),
      constraints_(std::move(constraints)),
      settings_(settings),
      smooth_(model, settings.smooth,
              [this](double, const VectorX& q, const VectorX& v, VectorX& tau) {
                if (closed_set_.empty()) return;
                closedForces(q, v, closed_lambda_);
                for (std::size_t k = 0; k < closed_set_.size(); ++k)
                  tau += constraints_[closed_set_[k]].normal(q) *
                         closed_lambda_[static_cast<Eigen::Index>(k)];
              }),
      data_(model),
      touching_(constraints_.size()),
      closed_(constraints_.size(), 0) {
  if (constraints_.size() > 12)
    throw InputError("event-driven reference: at most 12 constraints, got " +
                     std::to_string(constraints_.size()));
  for (const UnilateralConstraint& c : constraints_) {
    if (!c.gap || !c.normal) throw InputError("event-driven reference: constraint without gap");
    if (!(c.restitution >= 0.0 && c.restitution <= 1.0))
      throw InputError("event-driven reference: restitution must be in [0, 1], got " +
                       formatValue(c.restitution));
  }
  smooth_.setEvents(static_cast<int>(constraints_.size()),
                    [this](double, const VectorX& q, const VectorX& v, VectorX& g) {
                      for (std::size_t i = 0; i < constraints_.size(); ++i)
                        if (!closed_[i]) g[static_cast<Eigen::Index>(i)] = constraints_[i].gap(q);
                      if (closed_set_.empty()) return;
                      closedForces(q, v, closed_lambda_);
                      for (std::size_t k = 0; k < closed_set_.size(); ++k)
                        g[closed_set_[k]] = closed_lambda_[static_cast<Eigen::Index>(k)];
                    });
}

void EventDrivenReference::reset(double t0, const VectorX& q0, const VectorX& v0) {
  impacts_.clear();
  phases_.clear();
  accumulated_ = false;
  std::fill(closed_.begin(), closed_.end(), 0);
  closed_set_.clear();
  for (std::size_t i = 0; i < constraints_.size(); ++i)
    if (constraints_[i].gap(q0) < -settings_.touch_tolerance)
      throw InputError("event-driven reference: constraint " + std::to_string(i) +
                       " is violated at the start (gap " + formatValue(constraints_[i].gap(q0)) +
                       ")");
  updateClosedSet(q0, v0);
  smooth_.reset(t0, q0, v0);
}

double EventDrivenReference::curvature(int i, const VectorX& q, const VectorX& v) const {
  const UnilateralConstraint& c = constraints_[i];
  if (c.curvature) return c.curvature(q, v);
  // d/dt W(q)^T v at fixed v, by a central difference along qdot = v (the test systems have
  // q = angles and positions, no quaternions)
  const double norm = v.norm();
  if (norm == 0.0) return 0.0;
  const double step = 1e-5 / norm;
  return (c.normal(q + step * v) - c.normal(q - step * v)).dot(v) / (2.0 * step);
}

void EventDrivenReference::delassus(const VectorX& q, const std::vector<int>& set, MatrixX& G) {
  crba(model_, data_, q);
  factorizeMassMatrix(model_, data_);
  const Eigen::Index n = static_cast<Eigen::Index>(set.size());
  for (int i : set) {
    touching_[i].W = constraints_[i].normal(q);
    applyMassInverse(model_, data_, touching_[i].W, touching_[i].minv_W);
  }
  G.resize(n, n);
  for (Eigen::Index r = 0; r < n; ++r)
    for (Eigen::Index c = 0; c < n; ++c)
      G(r, c) = touching_[set[r]].W.dot(touching_[set[c]].minv_W);
}

void EventDrivenReference::closedForces(const VectorX& q, const VectorX& v, VectorX& lambda) {
  const VectorX no_force = VectorX::Zero(model_.nv);
  const VectorX a_free = forwardDynamics(model_, data_, q, v, no_force);
  MatrixX G;
  delassus(q, closed_set_, G);
  VectorX rhs(static_cast<Eigen::Index>(closed_set_.size()));
  for (std::size_t k = 0; k < closed_set_.size(); ++k) {
    const int i = closed_set_[k];
    rhs[static_cast<Eigen::Index>(k)] = -(touching_[i].W.dot(a_free) + curvature(i, q, v));
  }
  lambda = G.ldlt().solve(rhs);
}

void EventDrivenReference::updateClosedSet(const VectorX& q, const VectorX& v) {
  // candidates: touching with zero normal velocity
  std::vector<int> candidates;
  const double speed_scale = 1e-9 * std::max(1.0, v.cwiseAbs().maxCoeff());
  for (std::size_t i = 0; i < constraints_.size(); ++i) {
    if (std::abs(constraints_[i].gap(q)) > settings_.touch_tolerance) continue;
    if (std::abs(constraints_[i].normal(q).dot(v)) > speed_scale) continue;
    candidates.push_back(static_cast<int>(i));
  }
  std::vector<char> now_closed(constraints_.size(), 0);
  if (!candidates.empty()) {
    const VectorX no_force = VectorX::Zero(model_.nv);
    const VectorX a_free = forwardDynamics(model_, data_, q, v, no_force);
    MatrixX G;
    delassus(q, candidates, G);
    VectorX b(static_cast<Eigen::Index>(candidates.size())), lambda;
    for (std::size_t k = 0; k < candidates.size(); ++k)
      b[static_cast<Eigen::Index>(k)] =
          touching_[candidates[k]].W.dot(a_free) + curvature(candidates[k], q, v);
    if (!solveSmallLcp(G, b, lambda))
      throw std::runtime_error("event-driven reference: no consistent contact forces at t = " +
                               formatValue(smooth_.time()));
    for (std::size_t k = 0; k < candidates.size(); ++k)
      if (lambda[static_cast<Eigen::Index>(k)] > 0.0) now_closed[candidates[k]] = 1;
  }
  closed_set_.clear();
  for (std::size_t i = 0; i < constraints_.size(); ++i) {
    if (now_closed[i] && !closed_[i])
      phases_.push_back(
          {static_cast<int>(i), smooth_.time(), std::numeric_limits<double>::infinity()});
    if (!now_closed[i] && closed_[i])
      for (ContactPhase& phase : phases_)
        if (phase.constraint == static_cast<int>(i) && std::isinf(phase.t_open))
          phase.t_open = smooth_.time();
    closed_[i] = now_closed[i];
    if (closed_[i]) closed_set_.push_back(static_cast<int>(i));
  }
}

void EventDrivenReference::applyImpact(const std::vector<int>& hitting) {
  const VectorX q = smooth_.q();
  VectorX v = smooth_.v();
  // the set S: the hitting constraints, the closed ones, and any other touching and
  // approaching one
  std::vector<int> set;
  for (std::size_t i = 0; i < constraints_.size(); ++i) {
    const int index = static_cast<int>(i);
    const bool hits = std::find(hitting.begin(), hitting.end(), index) != hitting.end();
    const bool touches = std::abs(constraints_[i].gap(q)) <= settings_.touch_tolerance &&
                         constraints_[i].normal(q).dot(v) < 0.0;
    if (hits || closed_[i] || touches) set.push_back(index);
  }
  MatrixX G;
  delassus(q, set, G);
  const Eigen::Index n = static_cast<Eigen::Index>(set.size());
  VectorX before(n), b(n), P;
  for (Eigen::Index k = 0; k < n; ++k) {
    before[k] = touching_[set[k]].W.dot(v);
    b[k] = (1.0 + constraints_[set[k]].restitution) * std::min(before[k], 0.0);
  }
  if (!solveSmallLcp(G, b, P))
    throw std::runtime_error("event-driven reference: the impact at t = " +
                             formatValue(smooth_.time()) + " has no solution");
  for (Eigen::Index k = 0; k < n; ++k) v += P[k] * touching_[set[k]].minv_W;
  // a rebound too slow to follow ends an accumulation: the normal velocity becomes exactly
  // zero (an impulse of the order of accumulation_speed) and the contact may close
  std::vector<int> settled;
  for (Eigen::Index k = 0; k < n; ++k) {
    const double after = touching_[set[k]].W.dot(v);
    if (before[k] < 0.0 && P[k] > 0.0) {
      impacts_.push_back({smooth_.time(), set[k], before[k], after});
      if (after > 0.0 && after < settings_.accumulation_speed) {
        accumulated_ = true;
        settled.push_back(static_cast<int>(k));
      }
    }
  }
  if (!settled.empty()) {
    const Eigen::Index m = static_cast<Eigen::Index>(settled.size());
    MatrixX Gs(m, m);
    VectorX U(m);
    for (Eigen::Index r = 0; r < m; ++r) {
      U[r] = touching_[set[settled[r]]].W.dot(v);
      for (Eigen::Index c = 0; c < m; ++c) Gs(r, c) = G(settled[r], settled[c]);
    }
    const VectorX Ps = Gs.completeOrthogonalDecomposition().solve(-U);
    for (Eigen::Index r = 0; r < m; ++r) v += Ps[r] * touching_[set[settled[r]]].minv_W;
  }
  restart(q, v);
}

void EventDrivenReference::restart(const VectorX& q, const VectorX& v) {
  updateClosedSet(q, v);
  smooth_.reset(smooth_.time(), q, v);
}

void EventDrivenReference::advanceTo(double t_out) {
  while (smooth_.time() < t_out) {
    const bool at_root = smooth_.advanceTo(t_out);
    for (std::size_t i = 0; i < constraints_.size(); ++i) {
      if (closed_[i]) continue;
      const double gap = constraints_[i].gap(smooth_.q());
      if (gap < -settings_.touch_tolerance)
        throw std::runtime_error("event-driven reference: constraint " + std::to_string(i) +
                                 " crossed without a root at t = " + formatValue(smooth_.time()) +
                                 " (gap " + formatValue(gap) + ")");
    }
    if (!at_root) return;
    std::vector<int> hitting;
    bool opening = false;
    for (std::size_t i = 0; i < constraints_.size(); ++i) {
      if (smooth_.events()[i] == 0) continue;
      if (closed_[i])
        opening = true;
      else
        hitting.push_back(static_cast<int>(i));
    }
    if (!hitting.empty()) {
      applyImpact(hitting);
    } else if (opening) {
      // a contact force reached zero: re-decide the closed set with it released
      const VectorX q = smooth_.q(), v = smooth_.v();
      for (std::size_t i = 0; i < constraints_.size(); ++i)
        if (smooth_.events()[i] != 0) closed_[i] = 0;
      for (ContactPhase& phase : phases_)
        if (smooth_.events()[phase.constraint] != 0 && std::isinf(phase.t_open))
          phase.t_open = smooth_.time();
      closed_set_.clear();
      for (std::size_t i = 0; i < constraints_.size(); ++i)
        if (closed_[i]) closed_set_.push_back(static_cast<int>(i));
      smooth_.reset(smooth_.time(), q, v);
    }
  }
}

}  // namespace sweep
