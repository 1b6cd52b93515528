#pragma once
// Scene files: YAML describing a scene (bodies, generators, URDF models, materials), the
// scheme and its settings, the time span and the outputs. The format is documented in
// docs/cli.md; every rejection names the file, the field path and the value.
#include <optional>
#include <string>
#include <vector>

#include "integrators/time_stepper.hpp"
#include "models/powder_bed.hpp"
#include "models/scene_spec.hpp"

namespace sweep {

struct OutputSettings {
  bool stats = true;  // stats.csv, one row per step
  // stats.csv's four time-per-stage columns; without them the file is a pure function of the
  // scene, the build and the thread count (bitwise-identical across runs)
  bool timings = true;
  long vtk_every = 0;         // VTK snapshot every N steps (0: off)
  double vtk_interval = 0.0;  // or every so much simulated time (0: off)
  // layer metrics of the spheres at the end of the run (layer.json, layer_height.png)
  std::optional<LayerWindow> layer;
};

struct RunSettings {
  SchemeSettings scheme;
  double t_end = 0.1;
  OutputSettings output;
};

struct SceneFile {
  std::string path;
  SceneSpec spec;
  RunSettings run;
};

// Reads and validates a scene file after applying the entries of `settings_files` (as
// --set-file gives them, in order) and then `overrides` (path=value, as --set gives them), so
// the command line has the last word. InputError for anything wrong, naming file, field and
// value.
SceneFile loadSceneFile(const std::string& path, const std::vector<std::string>& overrides = {},
                        const std::vector<std::string>& settings_files = {});

// The most bodies one generator may make.
inline constexpr long kMaxGeneratorCount = 10000000;

// The same from YAML text; `path` names it in messages and anchors relative file names.
// max_count lowers the generator limit (the fuzzer keeps inputs small with it).
SceneFile loadSceneText(const std::string& text, const std::string& path,
                        long max_count = kMaxGeneratorCount);
// The same with settings files and overrides applied, as loadSceneFile does.
SceneFile loadSceneText(const std::string& text, const std::string& path,
                        const std::vector<std::string>& overrides,
                        const std::vector<std::string>& settings_files);

// Builds the Model, contact model and initial state; InputError names the file.
Scene buildSceneFile(const SceneFile& file);

// Writes the scene as an explicit file (every body listed, no generators) that loads back to
// the same scene: generators are a convenience, not the only way to say a scene.
void writeSceneFile(const SceneFile& scene, const std::string& path);

}  // namespace sweep
