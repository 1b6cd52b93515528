// libFuzzer target: saved states (`sweep run --initial-state`, docs/cli.md). Each input is the
// text of a final_state.csv for tests/data/scenes/small_box.yaml (24 disks, walls, a driven
// paddle); an accepted state then runs two steps of each scheme. Any input must end in a run or
// an InputError / runtime_error, as in scene_fuzzer.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "apps/sweep/run.hpp"
#include "apps/sweep/scene_file.hpp"
#include "framework/error.hpp"
#include "integrators/time_stepper.hpp"

namespace {

const char* const kScene = SWEEP_SOURCE_DIR "/tests/data/scenes/small_box.yaml";

struct Loaded {
  sweep::SceneFile file;
  sweep::Scene scene;
};

const Loaded& loaded() {
  static const Loaded instance = [] {
    Loaded l;
    l.file = sweep::loadSceneFile(kScene);
    l.scene = sweep::buildSceneFile(l.file);
    return l;
  }();
  return instance;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* bytes, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(bytes), size);
  const Loaded& l = loaded();
  try {
    const sweep::SavedState state =
        sweep::readSavedStateText(text, "fuzz_state.csv", l.scene, l.file.spec.max_initial_overlap);
    for (const sweep::Scheme scheme : {sweep::Scheme::MoreauJean, sweep::Scheme::CatchingUp}) {
      sweep::SchemeSettings settings = l.file.run.scheme;
      settings.scheme = scheme;
      settings.coulomb.max_iterations = 50;
      settings.normal_stage.max_iterations = 50;
      settings.friction_stage.max_iterations = 50;
      sweep::TimeStepper stepper(l.scene.model, l.scene.cmodel, settings, l.scene.forces);
      stepper.reset(state.t, state.q, state.v);
      for (int k = 0; k < 2; ++k) stepper.step();
    }
  } catch (const sweep::InputError&) {
  } catch (const std::runtime_error&) {
  }
  return 0;
}
