#pragma once
// Contact-free reference integrator on SUNDIALS CVODE (variable-order Adams-Moulton with a
// fixed-point corrector: the dynamics of the test systems are not stiff, and this avoids a
// Jacobian). State y = (q, v), ydot = (qdot(q, v), M^-1 (tau - b)). Tolerances default tight
// enough to serve as the oracle for energy and momentum conservation tests, and, with event
// functions (CVODE's root finding on gaps), as the event-driven reference of the validation
// cases: integrate to the next root, apply the impact law, reset, go on.
#include <functional>
#include <memory>
#include <vector>

#include "framework/data.hpp"

namespace sweep {

struct SmoothReferenceSettings {
  double relative_tolerance = 1e-12;
  double absolute_tolerance = 1e-14;
  long max_steps = 50'000'000;
  int max_order = 12;  // Adams order cap

  void validate() const;  // throws InputError
};

class SmoothReferenceIntegrator {
 public:
  // Applied generalized force tau(t, q, v), added to gravity; none by default.
  using ForceFunction =
      std::function<void(double t, const VectorX& q, const VectorX& v, VectorX& tau)>;
  // Event functions g(t, q, v) (one entry each, e.g. gaps), watched for crossings from
  // positive to negative.
  using EventFunction =
      std::function<void(double t, const VectorX& q, const VectorX& v, VectorX& g)>;

  explicit SmoothReferenceIntegrator(const Model& model, SmoothReferenceSettings settings = {},
                                     ForceFunction force = nullptr);
  ~SmoothReferenceIntegrator();
  SmoothReferenceIntegrator(const SmoothReferenceIntegrator&) = delete;
  SmoothReferenceIntegrator& operator=(const SmoothReferenceIntegrator&) = delete;

  // Before the first reset(): count event functions to watch.
  void setEvents(int count, EventFunction events);

  void reset(double t0, const VectorX& q0, const VectorX& v0);
  // Integrates to t_out, or to the first root of an event function before it (throws
  // std::runtime_error naming CVODE's flag on failure); q is returned with normalized
  // quaternions. Returns true when stopped at a root; events() then flags which ones.
  bool advanceTo(double t_out);
  const std::vector<int>& events() const { return roots_; }

  double time() const { return t_; }
  const VectorX& q() const { return q_; }
  const VectorX& v() const { return v_; }
  long steps() const;

 private:
  struct Cvode;
  friend struct Cvode;
  void derivative(double t, const double* y, double* ydot);
  void eventValues(double t, const double* y, double* g);

  const Model& model_;
  Data data_;
  SmoothReferenceSettings settings_;
  ForceFunction force_;
  EventFunction events_;
  int event_count_ = 0;
  std::vector<int> roots_;
  VectorX event_values_;
  VectorX q_, v_, tau_, qdot_;
  double t_ = 0.0;
  std::unique_ptr<Cvode> cvode_;
};

}  // namespace sweep
