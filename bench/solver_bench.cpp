// Cost of one contact update in the NLGS solvers of both schemes (issue #4 targets: <= 30 ns
// in 2D, <= 80 ns in 3D). A 2000-grain box is let fall until a dense contact network has
// formed; then, over the next steps, solve time / local solves (every island, sweep and stage).
// Prints CSV. Run: ./build/bench/solver_bench [2|3]
#include <chrono>
#include <cstdio>
#include <cstdlib>

#include "integrators/time_stepper.hpp"
#include "models/granular.hpp"

using namespace sweep;

int main(int argc, char** argv) {
  // optional argument: 2 or 3, one dimension only
  const int only = argc > 1 ? std::atoi(argv[1]) : 0;
  std::printf("dimension,scheme,grains,steps,mean_active,updates,solve_seconds,ns_per_update\n");
  for (bool planar : {true, false}) {
    if (only != 0 && only != (planar ? 2 : 3)) continue;
    GranularBoxParameters parameters;
    parameters.count = 2000;
    parameters.planar = planar;
    parameters.width = planar ? 0.1 : 0.025;
    const Scene scene = granularBox(parameters);
    for (Scheme scheme : {Scheme::MoreauJean, Scheme::CatchingUp}) {
      SchemeSettings settings;
      settings.scheme = scheme;
      settings.h = 2e-4;
      // the per-update cost, not convergence, is measured: a moderate cap keeps this short
      settings.coulomb.max_iterations = 300;
      settings.normal_stage.max_iterations = settings.friction_stage.max_iterations = 150;
      TimeStepper stepper(scene.model, scene.cmodel, settings);
      stepper.reset(0.0, scene.q0, scene.v0);
      for (int k = 0; k < 250; ++k) stepper.step();
      double solve = 0.0, updates = 0.0, active = 0.0;
      const int steps = 40;
      for (int k = 0; k < steps; ++k) {
        const StepStats& s = stepper.step();
        solve += s.t_solve;
        updates += static_cast<double>(s.updates);
        active += s.active;
      }
      std::printf("%d,%s,%d,%d,%.0f,%.0f,%.4f,%.1f\n", planar ? 2 : 3, enumName(scheme),
                  parameters.count, steps, active / steps, updates, solve, 1e9 * solve / updates);
      std::fflush(stdout);
    }
  }
}
