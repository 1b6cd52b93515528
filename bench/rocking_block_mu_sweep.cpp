// V5, Housner's rocking block, against the friction coefficient (docs/validation.md): the
// ratio omega+ / omega- at the first corner impact and the impacting corner's slip in that
// step, for both schemes, as CSV. The reference (section 6, V5) expects the Housner ratio
// once the corner sticks: mu >= 0.45 for Jean-Moreau, mu >= 0.666 under the staggered
// reconstruction. Run: ./build/bench/rocking_block_mu_sweep
#include <cstdio>

#include "apps/sweep/validation.hpp"

using namespace sweep;

int main() {
  std::printf("mu,scheme,ratio,housner,corner_slip\n");
  for (double mu : {0.3, 0.4, 0.44, 0.46, 0.5, 0.6, 0.64, 0.66, 0.68, 0.7, 0.8, 1.0}) {
    RockingBlockParameters parameters;
    parameters.friction = mu;
    for (Scheme scheme : {Scheme::MoreauJean, Scheme::CatchingUp}) {
      // the staggered scheme also with ten threshold updates (FrictionStageOptions)
      for (int updates : {0, 10}) {
        if (scheme == Scheme::MoreauJean && updates > 0) continue;
        const RockingImpact impact = rockingBlockFirstImpact(parameters, scheme, 1e-4, updates);
        std::printf("%.2f,%s%s,%.6f,%.6f,%.3e\n", mu, enumName(scheme),
                    updates > 0 ? " threshold-updates-10" : "", impact.ratio,
                    housnerRatio(parameters), impact.corner_slip);
      }
    }
    std::fflush(stdout);
  }
  return 0;
}
