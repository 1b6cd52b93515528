// libFuzzer target: settings files (`sweep --set-file`, docs/cli.md), and with them the field
// path walker that `--set` shares. Each input is a settings file applied to small_box.yaml (2D,
// generators, bodies, material pairs, a driven body), and the result is parsed and built. Any
// input must end in a scene or an InputError / runtime_error, as in scene_fuzzer.
#include <yaml-cpp/yaml.h>

#include <cstddef>
#include <cstdint>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

#include "apps/sweep/scene_file.hpp"
#include "apps/sweep/yaml_field.hpp"
#include "framework/error.hpp"

namespace {

const char* const kScene = SWEEP_SOURCE_DIR "/tests/data/scenes/small_box.yaml";

const std::string& sceneText() {
  static const std::string text = [] {
    std::ifstream in(kScene);
    std::stringstream buffer;
    buffer << in.rdbuf();
    return buffer.str();
  }();
  return text;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* bytes, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(bytes), size);
  try {
    const YAML::Node settings = sweep::parseYamlText(text, "fuzz.yaml");
    YAML::Node root = YAML::Load(sceneText());
    for (const sweep::FieldOverride& entry : sweep::overridesFromYaml(settings, "fuzz.yaml"))
      sweep::applyOverride(root, entry, kScene);
    YAML::Emitter merged;
    merged << root;
    if (!merged.good()) return 0;
    // generators stay small, so that one input is one quick build
    sweep::SceneFile file = sweep::loadSceneText(merged.c_str(), kScene, 500);
    sweep::buildSceneFile(file);
    file.run.scheme.validate();
  } catch (const sweep::InputError&) {
  } catch (const std::runtime_error&) {
  }
  return 0;
}
