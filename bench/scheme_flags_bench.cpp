// Flag combinations of both schemes on a compacting pile of 100 disks (granularBox, h = 2e-4,
// 800 steps): sweeps per stage, cap hits, penetration and final kinetic energy, as CSV.
// The table in docs/schemes.md comes from this. Run: ./build/bench/scheme_flags_bench
#include <algorithm>
#include <cstdio>

#include "integrators/time_stepper.hpp"
#include "models/granular.hpp"

using namespace sweep;

int main() {
  GranularBoxParameters parameters;
  parameters.count = 100;
  const Scene scene = granularBox(parameters);
  struct Flags {
    Scheme scheme;
    TangentMode tangents;
    NormalLaw law;
    OpenContacts open = OpenContacts::Unilateral;  // GLOBAL's stage 5b
  };
  const Flags runs[] = {
      {Scheme::MoreauJean, TangentMode::Global, NormalLaw::Vel},
      {Scheme::MoreauJean, TangentMode::Global, NormalLaw::Pos},
      {Scheme::CatchingUp, TangentMode::Global, NormalLaw::Vel},
      {Scheme::CatchingUp, TangentMode::Global, NormalLaw::Vel, OpenContacts::Free},
      {Scheme::CatchingUp, TangentMode::Global, NormalLaw::Pos},
      {Scheme::CatchingUp, TangentMode::Global, NormalLaw::Pos, OpenContacts::Free},
      {Scheme::CatchingUp, TangentMode::Local, NormalLaw::Vel},
      {Scheme::CatchingUp, TangentMode::Local, NormalLaw::Iqs},
      {Scheme::CatchingUp, TangentMode::Local, NormalLaw::Pos},
  };
  std::printf(
      "scheme,tangents,open_contacts,law,mean_sweeps_1,mean_sweeps_2,max_sweeps_1,max_sweeps_2,"
      "cap_hit_steps,peak_penetration,cumulative_penetration,final_kinetic\n");
  const int steps = 800;
  for (const Flags& flags : runs) {
    SchemeSettings settings;
    settings.scheme = flags.scheme;
    settings.h = 2e-4;
    settings.normal_law = flags.law;
    settings.friction.tangents = flags.tangents;
    settings.friction.open_contacts = flags.open;
    TimeStepper stepper(scene.model, scene.cmodel, settings);
    stepper.reset(0.0, scene.q0, scene.v0);
    long sweeps1 = 0, sweeps2 = 0;
    int max1 = 0, max2 = 0, caps = 0;
    double peak = 0.0, cumulative = 0.0;
    for (int k = 0; k < steps; ++k) {
      const StepStats& s = stepper.step();
      sweeps1 += s.iterations_stage1;
      sweeps2 += s.iterations_stage2;
      max1 = std::max(max1, s.iterations_stage1);
      max2 = std::max(max2, s.iterations_stage2);
      caps += s.cap_hit ? 1 : 0;
      peak = std::max(peak, s.penetration_max);
      cumulative += s.penetration_sum;
    }
    const bool global_b =
        flags.scheme == Scheme::CatchingUp && flags.tangents == TangentMode::Global;
    std::printf("%s,%s,%s,%s,%.0f,%.0f,%d,%d,%d,%.3g,%.3g,%.3g\n", enumName(flags.scheme),
                flags.scheme == Scheme::CatchingUp ? enumName(flags.tangents) : "-",
                global_b ? enumName(flags.open) : "-", enumName(flags.law),
                static_cast<double>(sweeps1) / steps, static_cast<double>(sweeps2) / steps, max1,
                max2, caps, peak, cumulative, stepper.stats().kinetic);
    std::fflush(stdout);
  }
}
