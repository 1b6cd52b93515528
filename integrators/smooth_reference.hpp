#pragma once
// Contact-free reference integrator on SUNDIALS CVODE (variable-order Adams-Moulton with a
// fixed-point corrector: the dynamics of the test systems are not stiff, and this avoids a
// Jacobian). State y = (q, v), ydot = (qdot(q, v), M^-1 (tau - b)). Tolerances default tight
// enough to serve as the oracle for energy and momentum conservation tests and, later, as the
// event-driven reference with root finding on gaps.
#include <functional>
#include <memory>

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

  explicit SmoothReferenceIntegrator(const Model& model, SmoothReferenceSettings settings = {},
                                     ForceFunction force = nullptr);
  ~SmoothReferenceIntegrator();
  SmoothReferenceIntegrator(const SmoothReferenceIntegrator&) = delete;
  SmoothReferenceIntegrator& operator=(const SmoothReferenceIntegrator&) = delete;

  void reset(double t0, const VectorX& q0, const VectorX& v0);
  // Integrates to t_out (throws std::runtime_error naming CVODE's flag on failure); q is
  // returned with normalized quaternions.
  void advanceTo(double t_out);

  double time() const { return t_; }
  const VectorX& q() const { return q_; }
  const VectorX& v() const { return v_; }
  long steps() const;

 private:
  struct Cvode;
  friend struct Cvode;
  void derivative(double t, const double* y, double* ydot);

  const Model& model_;
  Data data_;
  SmoothReferenceSettings settings_;
  ForceFunction force_;
  VectorX q_, v_, tau_, qdot_;
  double t_ = 0.0;
  std::unique_ptr<Cvode> cvode_;
};

}  // namespace sweep
