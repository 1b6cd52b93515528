// Trajectories of the validation cases next to their event-driven references, for the
// figures of docs/validation.md: CSV case,source,t,x1,x2,energy,impulse with source one of
// reference, moreau-jean, catching-up. V1: x1 = centre height, x2 = vertical velocity.
// V10: x1, x2 = the absolute angles th1, th2. impulse: the normal impulses of the steps since
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

void schemes(const char* name, const Scene& scene, double h, double t_end, double interval,
             const Coordinates& coordinates) {
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
                  x[0], x[1], stepper.energy(), impulse);
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
  return 0;
}
