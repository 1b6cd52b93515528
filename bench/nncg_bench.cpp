// Scheme A's sweeps with and without the NNCG momentum (docs/schemes.md) on a settled powder
// heap, the problem that made the powder-bed pass slow (docs/powder_bed.md): a heap of COUNT
// spheres settles behind its walls for SETTLE steps; then two steppers start from that state,
// one per acceleration, and take the same STEPS steps, interleaved so that both see the same
// machine load. Prints CSV: sweeps per step, local solves, solve seconds, ns per local solve.
// Run: ./build/bench/nncg_bench [COUNT [SETTLE [STEPS]]]   (defaults 800 1500 400)
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "integrators/time_stepper.hpp"
#include "models/powder_bed.hpp"
#include "models/scene_spec.hpp"

using namespace sweep;

int main(int argc, char** argv) {
  const int count = argc > 1 ? std::atoi(argv[1]) : 800;
  const int settle = argc > 2 ? std::atoi(argv[2]) : 1500;
  const int steps = argc > 3 ? std::atoi(argv[3]) : 400;
  if (count < 10 || settle < 0 || steps < 1) {
    std::fprintf(stderr, "usage: nncg_bench [COUNT >= 10 [SETTLE >= 0 [STEPS >= 1]]]\n");
    return 2;
  }
  PowderBedParameters parameters;
  parameters.count = count;
  parameters.length = 2.0e-3;
  parameters.travel = 0.8e-3;
  parameters.heap_length = 0.6e-3;
  const Scene scene = buildScene(powderBed(parameters));
  SchemeSettings settings;
  settings.h = 1e-5;
  settings.normal_law = NormalLaw::Vel;
  settings.coulomb.tolerance = 1e-4;
  TimeStepper settling(scene.model, scene.cmodel, settings, scene.forces);
  settling.reset(0.0, scene.q0, scene.v0);
  for (int k = 0; k < settle; ++k) settling.step();

  const NlgsAcceleration accelerations[2] = {NlgsAcceleration::None, NlgsAcceleration::Nncg};
  std::vector<TimeStepper> steppers;
  steppers.reserve(2);  // no move: each keeps its workspaces in place
  for (const NlgsAcceleration acceleration : accelerations) {
    settings.coulomb.acceleration = acceleration;
    steppers.emplace_back(scene.model, scene.cmodel, settings, scene.forces);
    steppers.back().reset(settling.time(), settling.q(), settling.v());
  }
  double sweeps[2] = {0, 0}, updates[2] = {0, 0}, solve[2] = {0, 0}, active[2] = {0, 0};
  int cap_hits[2] = {0, 0};
  for (int k = 0; k < steps; ++k) {
    for (int i = 0; i < 2; ++i) {
      const StepStats& s = steppers[i].step();
      sweeps[i] += s.iterations_stage1;
      updates[i] += static_cast<double>(s.updates);
      solve[i] += s.t_solve;
      active[i] += s.active;
      cap_hits[i] += s.cap_hit ? 1 : 0;
    }
  }
  std::printf(
      "acceleration,spheres,settle_steps,steps,mean_active,sweeps_per_step,cap_hits,"
      "local_solves,solve_seconds,ns_per_local_solve\n");
  for (int i = 0; i < 2; ++i)
    std::printf("%s,%d,%d,%d,%.0f,%.1f,%d,%.0f,%.3f,%.1f\n", enumName(accelerations[i]), count,
                settle, steps, active[i] / steps, sweeps[i] / steps, cap_hits[i], updates[i],
                solve[i], 1e9 * solve[i] / updates[i]);
  std::printf("# solve time none / nncg: %.2f\n", solve[0] / solve[1]);
}
