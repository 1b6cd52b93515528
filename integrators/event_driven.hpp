#pragma once
// Event-driven reference for the validation cases (reference section 6, V1 and V10): the
// smooth dynamics between impacts on CVODE (SmoothReferenceIntegrator), CVODE's root finding
// on the gaps, and Newton's impact law applied at each root,
//   W_i^T v+ = -e_i W_i^T v-,   v+ = v- + M(q)^-1 W_i P,   P = -(1 + e_i) W_i^T v- / W_ii,
// one constraint at a time (isolated, frictionless impacts). It stops at an accumulation of
// impacts (Zeno): when a rebound is slower than `accumulation_speed`, the run ends there,
// since continuing would need a switch to persistent contact that this reference does not
// model. A gap found negative after a smooth stretch (a missed root) is an error, not a
// silently wrong reference.
#include <functional>
#include <vector>

#include "integrators/smooth_reference.hpp"

namespace sweep {

struct UnilateralConstraint {
  std::function<double(const VectorX& q)> gap;
  std::function<VectorX(const VectorX& q)> normal;  // W_i(q): dg/dt = W_i^T v
  double restitution = 0.0;
};

struct Impact {
  double t = 0.0;
  int constraint = 0;
  double normal_velocity_before = 0.0, normal_velocity_after = 0.0;
};

struct EventDrivenSettings {
  SmoothReferenceSettings smooth;
  // rebound normal speed below which impacts accumulate: CVODE's root finding loses flights
  // much shorter than its steps (at 1e-6 m/s under gravity a flight lasts 2e-7 s)
  double accumulation_speed = 1e-5;
};

class EventDrivenReference {
 public:
  EventDrivenReference(const Model& model, std::vector<UnilateralConstraint> constraints,
                       EventDrivenSettings settings = {});
  // the event functions hold `this`
  EventDrivenReference(const EventDrivenReference&) = delete;
  EventDrivenReference& operator=(const EventDrivenReference&) = delete;

  void reset(double t0, const VectorX& q0, const VectorX& v0);
  // Integrates to t_out through every impact before it, or stops at an accumulation point.
  void advanceTo(double t_out);

  double time() const { return smooth_.time(); }
  const VectorX& q() const { return smooth_.q(); }
  const VectorX& v() const { return smooth_.v(); }
  const std::vector<Impact>& impacts() const { return impacts_; }
  bool accumulated() const { return accumulated_; }

 private:
  const Model& model_;
  std::vector<UnilateralConstraint> constraints_;
  EventDrivenSettings settings_;
  SmoothReferenceIntegrator smooth_;
  Data data_;
  std::vector<Impact> impacts_;
  bool accumulated_ = false;
};

}  // namespace sweep
