// Convergence of the validation cases against their references (docs/validation.md): error
// against h, halved four times, for both schemes, as CSV (case,scheme,h,error,order).
// Run: ./build/bench/validation_convergence > conv.csv
//      /usr/bin/python3 scripts/plot_convergence.py conv.csv docs/figures/validation/
#include <cstdio>

#include "apps/sweep/validation.hpp"

using namespace sweep;

int main() {
  std::printf("case,scheme,h,error,order\n");
  const BouncingBallParameters ball;
  const std::vector<double> steps = {5e-3,     2.5e-3,    1.25e-3,  6.25e-4,
                                     3.125e-4, 1.5625e-4, 7.8125e-5};
  for (Scheme scheme : {Scheme::MoreauJean, Scheme::CatchingUp}) {
    const std::vector<ConvergencePoint> points =
        bouncingBallConvergence(ball, scheme, steps, 3.0, 5e-3);
    for (const ConvergencePoint& p : points)
      std::printf("V1_bouncing_ball,%s,%.6g,%.6e,%.3f\n", schemeName(scheme), p.h, p.error,
                  p.order);
    std::fprintf(stderr, "V1_bouncing_ball %s: fitted order %.3f\n", schemeName(scheme),
                 fittedOrder(points));
    std::fflush(stdout);
  }
  return 0;
}
