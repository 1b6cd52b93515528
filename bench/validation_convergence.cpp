// Convergence of the validation cases against their references (docs/validation.md): error
// against h, for both schemes (V7: Jean-Moreau only), as CSV (case,scheme,h,error,order);
// the fitted orders go to stderr.
// Run: ./build/bench/validation_convergence > conv.csv
//      /usr/bin/python3 scripts/plot_convergence.py conv.csv docs/figures/validation/
#include <cmath>
#include <cstdio>
#include <string>

#include "apps/sweep/validation.hpp"

using namespace sweep;

namespace {

void print(const char* name, Scheme scheme, const std::vector<ConvergencePoint>& points) {
  for (const ConvergencePoint& p : points)
    std::printf("%s,%s,%.6g,%.6e,%.3f\n", name, enumName(scheme), p.h, p.error, p.order);
  std::fprintf(stderr, "%s %s: fitted order %.3f\n", name, enumName(scheme), fittedOrder(points));
  std::fflush(stdout);
}

// h0 halved `halvings` times
std::vector<double> halved(double h0, int halvings) {
  std::vector<double> steps{h0};
  for (int k = 0; k < halvings; ++k) steps.push_back(steps.back() / 2.0);
  return steps;
}

SceneFile example(const char* name) {
  return loadSceneFile(std::string(SWEEP_SOURCE_DIR) + "/examples/archetypes/" + name + ".yaml");
}

}  // namespace

int main() {
  std::printf("case,scheme,h,error,order\n");
  const SceneFile ramp = example("ramp_force");
  for (Scheme scheme : {Scheme::MoreauJean, Scheme::CatchingUp}) {
    print("V1_bouncing_ball", scheme,
          bouncingBallConvergence(BouncingBallParameters{}, scheme, halved(5e-3, 6), 3.0, 5e-3));
    print("V3_ramp_force", scheme,
          rampForceConvergence(ramp, scheme, halved(1e-3, 4), 12.0, 0.5, 1.0));
    print("V5_rocking_block", scheme,
          rockingBlockConvergence(RockingBlockParameters{}, scheme, halved(1e-3, 6)));
    print("V10_wall_pendulum", scheme,
          wallPendulumConvergence(WallPendulumParameters{}, scheme, halved(5e-4, 4), 5.0, 0.01));
  }
  // V11 has no reference solution: self-convergence of the crank's angle at 0.2 s against a
  // run at h = 1.25e-6
  for (Scheme scheme : {Scheme::MoreauJean, Scheme::CatchingUp}) {
    const SliderCrankParameters crank;
    const double finest = sliderCrankRun(crank, scheme, 1.25e-6, 0.2).theta[0];
    print("V11_slider_crank", scheme, convergenceStudy(halved(2e-5, 3), [&](double h) {
            return std::abs(sliderCrankRun(crank, scheme, h, 0.2).theta[0] - finest);
          }));
  }
  {  // V9, Jean-Moreau (the staggered scheme does not peck): self-convergence of the peck
     // period (mean of cycles 2 to 7 in 1 s) against a run at h = 1.25e-6
    auto period = [](double h) {
      const WoodpeckerRun run = woodpeckerRun(WoodpeckerParameters{}, Scheme::MoreauJean, h, 1.0);
      if (run.beak_times.size() < 8) return std::nan("");
      return (run.beak_times[7] - run.beak_times[1]) / 6.0;
    };
    const double finest = period(1.25e-6);
    print(
        "V9_woodpecker_period", Scheme::MoreauJean,
        convergenceStudy(halved(4e-5, 4), [&](double h) { return std::abs(period(h) - finest); }));
  }
  print("V7_painleve_jam", Scheme::MoreauJean,
        painleveJamConvergence(example("painleve_rod"), halved(1e-3, 4)));
  return 0;
}
