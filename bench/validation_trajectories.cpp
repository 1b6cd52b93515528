// Trajectories of the validation cases next to their event-driven references, for the
// figures of docs/validation.md: CSV case,source,t,x1,x2,energy,impulse with source one of
// reference, moreau-jean, catching-up. V1: x1 = centre height, x2 = vertical velocity.
// V10: x1, x2 = the absolute angles th1, th2. V9 (no reference): x1 = the sleeve's height y,
// x2 = the bird's angle phi_S. V11 (no reference): x1 = the crank's rate, x2 = the slider
// centre's height in its guide. V3: x1 = the block's displacement, x2 = its speed (the
// reference is the exact solution). V5: x1 = the block's angle, x2 = its angular velocity.
// V7: x1 = the lower end's sliding speed, x2 = the rod's angle. impulse: the normal impulses of the
// steps since the previous sample (the time-stepping schemes; empty for the reference). Run:
// ./build/bench/validation_trajectories > traj.csv
//      /usr/bin/python3 scripts/plot_trajectories.py traj.csv docs/figures/validation/
#include <cstdio>
#include <functional>
#include <string>

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
      std::printf("%s,%s,%.6f,%.9e,%.9e,%.9e,%.6e\n", name, enumName(scheme), stepper.time(), x[0],
                  x[1], stepper.energy() + (extra ? extra(stepper.q()) : 0.0), impulse);
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
  {  // V3 from its example, against x(t) = k (t - t*)^3 / (6 m)
    const SceneFile file =
        loadSceneFile(std::string(SWEEP_SOURCE_DIR) + "/examples/archetypes/ramp_force.yaml");
    const Scene scene = buildSceneFile(file);
    const double k = 12.0, mu = 0.5, m = 1.0, g = 9.81, t_star = mu * m * g / k;
    for (long j = 0; j <= 100; ++j) {
      const double t = 0.01 * static_cast<double>(j), s = std::max(t - t_star, 0.0);
      std::printf("V3_ramp_force,reference,%.6f,%.9e,%.9e,,\n", t, k * s * s * s / (6.0 * m),
                  k * s * s / (2.0 * m));
    }
    const double x0 = scene.q0[0];
    schemes("V3_ramp_force", scene, 1e-3, 1.0, 0.01,
            [x0](const VectorX& q, const VectorX& v) { return Eigen::Vector2d(q[0] - x0, v[0]); });
  }
  {  // V5 at h = 1e-4, mu = 1 (both schemes stick)
    schemes("V5_rocking_block", rockingBlock(RockingBlockParameters{}), 1e-4, 2.0, 2e-3,
            [](const VectorX& q, const VectorX& v) { return Eigen::Vector2d(q[2], v[2]); });
  }
  {  // V7 from its example, 0.05 s
    const SceneFile file =
        loadSceneFile(std::string(SWEEP_SOURCE_DIR) + "/examples/archetypes/painleve_rod.yaml");
    const Scene scene = buildSceneFile(file);
    // the lower end A's horizontal speed: xdot + l sin(th) thdot (l = 0.5)
    schemes("V7_painleve_rod", scene, 1e-4, 0.05, 5e-4, [](const VectorX& q, const VectorX& v) {
      return Eigen::Vector2d(v[0] + 0.5 * std::sin(q[2]) * v[2], q[2]);
    });
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
