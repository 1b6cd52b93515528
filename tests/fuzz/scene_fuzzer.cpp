// libFuzzer target: scene files (docs/robustness.md). Any input must end in a scene, or in an
// InputError (the user's mistake, exit 2) or a runtime_error (exit 1): never a crash, a
// sanitizer report, a hang or another exception. A scene that builds is stepped twice by
// each scheme, so that odd but valid geometry reaches detection and the solvers.
// Relative file names resolve against examples/archetypes, so the seeds' URDFs load.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include "apps/sweep/scene_file.hpp"
#include "framework/error.hpp"
#include "integrators/time_stepper.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* bytes, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(bytes), size);
  try {
    // generators stay small, so that one input is one quick run
    sweep::SceneFile file =
        sweep::loadSceneText(text, SWEEP_SOURCE_DIR "/examples/archetypes/fuzz.yaml", 500);
    const sweep::Scene scene = sweep::buildSceneFile(file);
    if (scene.model.nv > 6000) return 0;
    for (sweep::Scheme scheme : {sweep::Scheme::MoreauJean, sweep::Scheme::CatchingUp}) {
      sweep::SchemeSettings settings = file.run.scheme;
      settings.scheme = scheme;
      // caps and steps small: the fuzzer is after crashes, not answers
      settings.coulomb.max_iterations = std::min(settings.coulomb.max_iterations, 50);
      settings.normal_stage.max_iterations = std::min(settings.normal_stage.max_iterations, 50);
      settings.friction_stage.max_iterations = std::min(settings.friction_stage.max_iterations, 50);
      sweep::TimeStepper stepper(scene.model, scene.cmodel, settings, scene.forces);
      stepper.reset(0.0, scene.q0, scene.v0);
      stepper.step();
      stepper.step();
    }
  } catch (const sweep::InputError&) {
  } catch (const std::runtime_error&) {
  }
  return 0;
}
