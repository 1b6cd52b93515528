#pragma once
// The scene file's parser (internal to apps/sweep): one member per part of the file, each
// checking its fields and naming the bad one. scene_file.cpp holds the document's top level,
// materials, contact laws, bodies, URDFs and loads; scene_generators.cpp the generators and the
// memory they plan; scene_settings.cpp detection, the scheme and its solvers, time and outputs.
#include <limits>
#include <optional>
#include <string>

#include "apps/sweep/scene_file.hpp"
#include "apps/sweep/yaml_field.hpp"

namespace sweep {

class SceneParser {
 public:
  SceneParser(const std::string& path, SceneFile& out, long max_count)
      : path_(path), out_(out), max_count_(max_count) {}
  void parse(const YamlField& root);

 private:
  void parseMaterials(const YamlField& materials);
  void addMaterial(const MaterialSpec& material, const YamlField& where);
  ContactLaw parseLaw(const YamlField& f, const ContactLaw& fallback);
  void parseContact(const YamlField& contact);
  void requireMaterial(const YamlField& where, const std::string& name);
  // a mesh's file and scale are kept in `spec` for export
  Shape parseShape(const YamlField& body, const std::string& type, BodySpec& spec);
  BodySpec parseBody(const YamlField& f);
  MotionSpec parseMotion(const YamlField& f);
  RadiusDistribution parseRadius(const YamlField& f);
  void parseGenerators(const YamlField& generators);
  void latticeGenerator(const YamlField& g, bool disks);
  void hallFunnelGenerator(const YamlField& g);
  // Runs a scene builder for generator g and merges its materials, laws and bodies. The
  // builder names the parameter in its errors; this adds where it came from.
  template <class Build>
  SceneSpec addGenerated(const YamlField& g, Build&& build);
  void powderBedGenerator(const YamlField& g);
  void parseUrdfs(const YamlField& list);
  // a value (a constant) or {times: [...], values: [...]}, linear between the times
  static TimeTable timeTable(const YamlField& f);
  // urdf[].actuators: {JOINT: {torque, kp, kd, position, velocity, max_torque}}
  void parseActuators(const YamlField& map, UrdfSpec& u);
  // loads: a force and a torque on a dynamic body, each a constant plus a rate (a ramp)
  void parseLoads(const YamlField& list);
  void parseDetection(const YamlField& f);
  // convex: a stage of scheme B, which may take the convex solver
  // stage: one of scheme B's stages, which choose their solver; scheme A's coupled problem
  // is not convex and takes NLGS only, with its 3D local solver and its coloured sweeps
  SolverSettings parseSolver(const YamlField& f, SolverSettings s, bool stage);
  void parseScheme(const YamlField& f);
  void parseTime(const YamlField& f);
  void parseOutput(const YamlField& f);
  void checkNames(const YamlField& root);

  // Resident memory per body, measured through one step of 10^5 and 4 x 10^5 generated disks
  // and spheres (3.8 to 4.6 kB); 5 kB keeps a margin. Checked before a generator allocates.
  static constexpr double kBytesPerBody = 5000.0;
  void planBodies(const YamlField& field, long count);
  std::string countLimit() const;

  const std::string& path_;
  SceneFile& out_;
  const long max_count_;                     // bodies per generator
  double planned_bodies_ = 0.0;              // generated so far, for the memory estimate
  std::optional<LayerWindow> powder_layer_;  // the powder_bed generator's default window
  // spec.bodies from here on are the file's bodies list
  std::size_t explicit_from_ = std::numeric_limits<std::size_t>::max();
};

}  // namespace sweep
