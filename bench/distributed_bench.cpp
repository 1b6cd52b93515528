// Scheme A over ranks (integrators/distributed_stepper.hpp) on a real scene from a saved
// state: STEPS steps on every rank of the mpiexec, then one line with the ranks, grains, wall
// time per step, bytes sent per step (all ranks), shared bodies and exchanges per step, the
// slowest solve's sweeps per step, the cap hits and the work imbalance. With SERIAL=1 (one
// rank) the plain TimeStepper runs the same steps instead: the single-process build's time.
// Usage: [mpiexec -n R] distributed_bench SCENE.yaml STATE.csv STEPS [KEY=VALUE ...]
//   KEY=VALUE as `sweep run --set`; INTERFACE=split for the split masses (RankInterface),
//   SWEEPS=k their sweeps between glues; REBALANCE=n steps between rebalances; SERIAL=1.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

#include "apps/sweep/run.hpp"
#include "apps/sweep/scene_file.hpp"
#include "framework/error.hpp"
#include "integrators/distributed_stepper.hpp"
#include "integrators/time_stepper.hpp"

namespace {
bool readCount(const std::string& arg, const char* key, int& out) {
  const std::string prefix = std::string(key) + "=";
  if (arg.rfind(prefix, 0) != 0) return false;
  char* end = nullptr;
  const long value = std::strtol(arg.c_str() + prefix.size(), &end, 10);
  if (end == arg.c_str() + prefix.size() || *end != '\0' || value < 0 || value > 1000000)
    throw sweep::InputError(std::string("distributed_bench: ") + key + " must be a count, got '" +
                            (arg.c_str() + prefix.size()) + "'");
  out = static_cast<int>(value);
  return true;
}
}  // namespace

int main(int argc, char** argv) {
  sweep::MpiSession mpi(argc, argv);
  const sweep::RankGroup ranks = sweep::RankGroup::world();
  if (argc < 4) {
    if (ranks.rank() == 0)
      std::fprintf(stderr, "usage: distributed_bench SCENE.yaml STATE.csv STEPS [KEY=VALUE ...]\n");
    return 2;
  }
  try {
    int steps = 0, serial = 0;
    sweep::DistributedSettings distributed;
    std::vector<std::string> overrides;
    readCount(std::string("STEPS=") + argv[3], "STEPS", steps);
    for (int k = 4; k < argc; ++k) {
      const std::string arg = argv[k];
      if (arg == "INTERFACE=split") {
        distributed.interface = sweep::RankInterface::SplitMasses;
        continue;
      }
      if (!readCount(arg, "SWEEPS", distributed.sweeps_per_exchange) &&
          !readCount(arg, "REBALANCE", distributed.rebalance_interval) &&
          !readCount(arg, "SERIAL", serial))
        overrides.push_back(arg);
    }
    if (serial && ranks.size() > 1)
      throw sweep::InputError("distributed_bench: SERIAL=1 runs on one rank");
    sweep::SceneFile file = sweep::loadSceneFile(argv[1], overrides);
    const sweep::Scene scene = sweep::buildSceneFile(file);
    const sweep::SavedState state = sweep::readSavedState(argv[2], scene, 1.0);
    long sweeps = 0, caps = 0, exchanges = 0, active = 0;
    double bytes = 0.0, shared = 0.0, imbalance = 0.0, seconds = 0.0;
    if (serial) {
      sweep::TimeStepper stepper(scene.model, scene.cmodel, file.run.scheme, scene.forces);
      stepper.reset(state.t, state.q, state.v);
      const auto start = std::chrono::steady_clock::now();
      for (int k = 0; k < steps; ++k) {
        const sweep::StepStats& s = stepper.step();
        sweeps += s.iterations_stage1;
        caps += s.cap_hit ? 1 : 0;
        active += s.active;
      }
      seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      imbalance = 1.0;
    } else {
      if (scene.forces)
        throw sweep::InputError("distributed_bench: the scene's loads do not run on ranks");
      sweep::DistributedStepper stepper(ranks, scene.model, scene.cmodel, file.run.scheme,
                                        distributed);
      stepper.reset(state.t, state.q, state.v);
      const auto start = std::chrono::steady_clock::now();
      for (int k = 0; k < steps; ++k) {
        const sweep::StepStats& s = stepper.step();
        const sweep::DistributedStats& d = stepper.distributedStats();
        sweeps += s.iterations_stage1;
        caps += s.cap_hit ? 1 : 0;
        active += s.active;
        bytes += static_cast<double>(d.bytes_sent);
        shared += static_cast<double>(d.shared_bodies);
        exchanges += d.exchanges;
        imbalance = std::max(imbalance, d.imbalance);
      }
      seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
    std::vector<double> slowest{seconds};
    ranks.max(slowest);
    if (ranks.rank() == 0) {
      const double n = steps > 0 ? steps : 1;
      std::printf(
          "ranks %d%s grains %zu steps %d: %.2f ms/step, %.0f bytes/step, %.1f shared bodies "
          "and %.1f exchanges per step, %.1f sweeps/step, %ld cap hits, %.1f rows/step, imbalance "
          "%.3f\n",
          ranks.size(), serial ? " (single process)" : "", scene.model.components.size(), steps,
          1e3 * slowest[0] / n, bytes / n, shared / n, exchanges / n, sweeps / n, caps, active / n,
          imbalance);
    }
  } catch (const sweep::InputError& e) {
    if (ranks.rank() == 0) std::fprintf(stderr, "%s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    ranks.abort(e.what(), 1);
  }
  return 0;
}
