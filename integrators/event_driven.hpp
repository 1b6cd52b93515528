#pragma once
// Event-driven reference for the validation cases (reference section 6, V1 and V10): the
// smooth dynamics between events on CVODE (SmoothReferenceIntegrator), CVODE's root finding,
// and an exact impact law at each root.
//
// Each unilateral constraint g_i(q) >= 0, dg_i/dt = W_i^T v, is open or closed.
// - Open: CVODE watches g_i for a downward crossing.
// - Impact at a root: Moreau-Newton's law on the set S of constraints that touch (the one
//   hitting, the closed ones, any other at zero gap and approaching),
//     v+ = v- + M^-1 W_S P,  0 <= W_i^T v+ + e_i W_i^T v-  _|_  P_i >= 0,  i in S,
//   solved exactly by enumerating the active sets (S is small).
// - Closed: a rebound slower than `accumulation_speed` (the end of a Zeno accumulation, or
//   e_i = 0) makes the normal velocity zero, and the contact persists while it pushes: the
//   constraint forces of the closed set C solve
//     W_C^T M^-1 W_C lambda = -(W_C^T a_free + v^T (d^2 g_C / dq^2) v),
//   and CVODE watches each lambda_i for a downward crossing, where the contact opens.
//   Which contacts close is decided by the acceleration-level complementarity problem.
// A gap of an open constraint found negative after a smooth stretch (a missed root) is an
// error, not a silently wrong reference.
#include <functional>
#include <vector>

#include "integrators/smooth_reference.hpp"

namespace sweep {

struct UnilateralConstraint {
  std::function<double(const VectorX& q)> gap;
  std::function<VectorX(const VectorX& q)> normal;  // W_i(q): dg/dt = W_i^T v
  // v^T (d^2 g / dq^2) v, the velocity-dependent part of d^2 g / dt^2; when absent, taken as
  // the central difference of W_i along v (relative error about 1e-10)
  std::function<double(const VectorX& q, const VectorX& v)> curvature;
  double restitution = 0.0;
};

struct Impact {
  double t = 0.0;
  int constraint = 0;
  double normal_velocity_before = 0.0, normal_velocity_after = 0.0;
};

// A persistent-contact phase of one constraint: [t_close, t_open) (t_open = inf while closed)
struct ContactPhase {
  int constraint = 0;
  double t_close = 0.0;
  double t_open = 0.0;
};

struct EventDrivenSettings {
  SmoothReferenceSettings smooth;
  // rebound normal speed below which impacts accumulate and the contact closes: CVODE's root
  // finding loses flights much shorter than its steps (at 1e-6 m/s under gravity a flight
  // lasts 2e-7 s)
  double accumulation_speed = 1e-5;
  // |g| below which a constraint counts as touching at an event (m or rad)
  double touch_tolerance = 1e-9;
};

class EventDrivenReference {
 public:
  EventDrivenReference(const Model& model, std::vector<UnilateralConstraint> constraints,
                       EventDrivenSettings settings = {});
  // the event and force functions hold `this`
  EventDrivenReference(const EventDrivenReference&) = delete;
  EventDrivenReference& operator=(const EventDrivenReference&) = delete;

  void reset(double t0, const VectorX& q0, const VectorX& v0);
  // Integrates to t_out through every impact, closing and opening before it.
  void advanceTo(double t_out);

  double time() const { return smooth_.time(); }
  const VectorX& q() const { return smooth_.q(); }
  const VectorX& v() const { return smooth_.v(); }
  const std::vector<Impact>& impacts() const { return impacts_; }
  const std::vector<ContactPhase>& phases() const { return phases_; }
  bool closed(int constraint) const { return closed_[constraint] != 0; }
  // whether an accumulation of impacts (Zeno) ended in a closed contact
  bool accumulated() const { return accumulated_; }

 private:
  struct Touching {
    VectorX W, minv_W;  // W_i and M^-1 W_i at the current q
  };
  // M^-1 W_i for the constraints in `set`, and the Delassus block G = W^T M^-1 W
  void delassus(const VectorX& q, const std::vector<int>& set, MatrixX& G);
  // forces of the closed set at (q, v), in order of closed_set_; false if G is singular
  void closedForces(const VectorX& q, const VectorX& v, VectorX& lambda);
  double curvature(int i, const VectorX& q, const VectorX& v) const;
  void applyImpact(const std::vector<int>& hitting);
  void updateClosedSet(const VectorX& q, const VectorX& v);
  void restart(const VectorX& q, const VectorX& v);

  const Model& model_;
  std::vector<UnilateralConstraint> constraints_;
  EventDrivenSettings settings_;
  SmoothReferenceIntegrator smooth_;
  Data data_;
  std::vector<Touching> touching_;
  std::vector<char> closed_;
  std::vector<int> closed_set_;
  VectorX closed_lambda_;
  std::vector<Impact> impacts_;
  std::vector<ContactPhase> phases_;
  bool accumulated_ = false;
};

// Solves 0 <= G x + b _|_ x >= 0 for a small positive semi-definite G (n <= 12) by
// enumerating the active sets; the solution with the fewest active entries is returned.
// False when none exists within `tolerance` (relative to the scale of b).
bool solveSmallLcp(const MatrixX& G, const VectorX& b, VectorX& x, double tolerance = 1e-10);

}  // namespace sweep
