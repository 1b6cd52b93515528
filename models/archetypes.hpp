#pragma once
// Small systems with known answers (reference section 6), shared by the validation tests,
// the convergence harness (bench/validation_convergence) and docs/validation.md.
#include "models/granular.hpp"

namespace sweep {

// V1, the bouncing ball with the Siconos BouncingBallTS parameters: a sphere of radius r on
// a free body whose centre starts at height drop + r above a floor half-space, at rest,
// frictionless, restitution e. The gap is q[2] - r; its normal in velocity space is v[2].
struct BouncingBallParameters {
  double mass = 1.0;
  double radius = 0.1;
  double drop = 1.0;  // initial gap (m)
  double restitution = 0.9;
  double gravity = 9.81;
};
Scene bouncingBall(const BouncingBallParameters& parameters);

// Analytic impact times of V1: t_1 = sqrt(2 drop / g), t_n = t_1 + (2 v_1 / g) sum_{j<n} e^j.
std::vector<double> bouncingBallImpactTimes(const BouncingBallParameters& parameters, int count);

}  // namespace sweep
