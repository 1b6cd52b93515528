// Trajectories of the validation cases next to their event-driven references, for the
// figures of docs/validation.md: CSV case,source,t,x1,x2,energy,impulse with source one of
// reference, moreau-jean, catching-up. V1: x1 = centre height, x2 = vertical velocity.
// V10: x1, x2 = the absolute angles th1, th2. V9 (no reference): x1 = the sleeve's height y,
// x2 = the bird's angle phi_S. V11 (no reference): x1 = the crank's rate, x2 = the slider
// centre's height in its guide. impulse: the normal impulses of the steps since
// the previous sample (the time-stepping schemes; empty for the reference).
// Run: ./build/bench/validation_trajectories > traj.csv
//      /usr/bin/python3 scripts/plot_trajectories.py traj.csv docs/figures/validation/
#include <cstdio>
#include <functional>

#include "apps/sweep/validation.hpp"
#include "framework/energy.hpp"
#include "framework/kinematics.hpp"

using namespace sweep;

namespace {

using Coordinates = std::function<Eigen::Vector2d(const VectorX& q, const VectorX& v)>;

double energyOf(const Model& model, Data& data, const VectorX& q, const VectorX& v) {
  forwardKinematics(model, data, q, v);
  return kineticEnergy(model, data) + potentialEnergy(model, data);
}

// potential energy the stepper does not see (springs in the scene's forces)
using ExtraPotential = std::function<double(const VectorX& q)>;

void schemes(const char* name, const Scene& scene, double h, double t_end, double interval,
             const Coordinates& coordinates, const ExtraPotential& extra = {}) {
  const long samples = std::lround(t_end / interval), per_sample = std::lround(interval / h);
  for (Scheme scheme : {Scheme::MoreauJean, Scheme::CatchingUp}) {
    SchemeSettings settings;
    settings.scheme = scheme;
    settings.h = h;
    settings.coulomb.tolerance = settings.normal_stage.tolerance = 1e-12;
    TimeStepper stepper(scene.model, scene.cmodel, settings, scene.forces);
    stepper.reset(0.0, scene.q0, scene.v0);
    for (long j = 0; j <= samples; ++j) {
      double impulse = 0.0;
      for (long k = 0; j > 0 && k < per_sample; ++k) {
        stepper.step();
        for (const Vector3& P : stepper.impulses()) impulse += P.x();
      }
      const Eigen::Vector2d x = coordinates(stepper.q(), stepper.v());
      std::printf("%s,%s,%.6f,%.9e,%.9e,%.9e,%.6e\n", name, schemeName(scheme), stepper.time(),
                  x[0], x[1], stepper.energy() + (extra ? extra(stepper.q()) : 0.0), impulse);
    }
  }
}

}  // namespace

int main() {
  std::printf("case,source,t,x1,x2,energy,impulse\n");
  {  // V1 at the Siconos step, through the accumulation and the rest after it
    const BouncingBallParameters ball;
    const Scene scene = bouncingBall(ball);
    const Coordinates height = [](const VectorX& q, const VectorX& v) {
      return Eigen::Vector2d(q[2], v[2]);
    };
    EventDrivenReference reference(scene.model, bouncingBallConstraints(ball));
    reference.reset(0.0, scene.q0, scene.v0);
    Data data(scene.model);
    for (long j = 0; j <= 1000; ++j) {
      reference.advanceTo(0.01 * static_cast<double>(j));
      const Eigen::Vector2d x = height(reference.q(), reference.v());
      std::printf("V1_bouncing_ball,reference,%.6f,%.9e,%.9e,%.9e,\n", reference.time(), x[0], x[1],
                  energyOf(scene.model, data, reference.q(), reference.v()));
    }
    schemes("V1_bouncing_ball", scene, 5e-3, 10.0, 0.01, height);
  }
  {  // V10 at the reference's step
    const WallPendulumParameters parameters;
    const Scene scene = wallPendulum(parameters);
    const Coordinates angles = [](const VectorX& q, const VectorX&) {
      return Eigen::Vector2d(q[0], q[0] + q[1]);
    };
    const WallPendulumReference reference = wallPendulumReference(parameters, 5.0, 0.01);
    Data data(scene.model);
    for (std::size_t j = 0; j < reference.q.size(); ++j) {
      const Eigen::Vector2d x = angles(reference.q[j], reference.v[j]);
      std::printf("V10_wall_pendulum,reference,%.6f,%.9e,%.9e,%.9e,\n",
                  0.01 * static_cast<double>(j), x[0], x[1],
                  energyOf(scene.model, data, reference.q[j], reference.v[j]));
    }
    schemes("V10_wall_pendulum", scene, 5e-4, 5.0, 0.01, angles);
  }
  {  // V9 at the Siconos step
    const WoodpeckerParameters parameters;
    const double c = parameters.c_phi;
    schemes(
        "V9_woodpecker", woodpecker(parameters), 2e-5, 0.6, 1e-3,
        [](const VectorX& q, const VectorX&) { return Eigen::Vector2d(q[0], q[1] + q[2]); },
        [c](const VectorX& q) { return 0.5 * c * q[2] * q[2]; });
  }
  {  // V11 at the reference's step
    const SliderCrankParameters p;
    schemes("V11_slider_crank", sliderCrank(p), 1e-5, 0.2, 2e-4,
            [p](const VectorX& q, const VectorX& v) {
              return Eigen::Vector2d(v[0], p.l1 * std::sin(q[0]) + p.l2 * std::sin(q[0] + q[1]));
            });
  }
  return 0;
}
