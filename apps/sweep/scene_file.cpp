#include "apps/sweep/scene_file.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <set>
#include <sstream>

#include "apps/sweep/run.hpp"
#include "apps/sweep/scene_parser.hpp"
#include "apps/sweep/signals.hpp"
#include "apps/sweep/yaml_field.hpp"
#include "contact/mesh_io.hpp"
#include "framework/error.hpp"
#include "framework/memory.hpp"
#include "models/funnel.hpp"
#include "models/powder_bed.hpp"

namespace sweep {

namespace {

namespace fs = std::filesystem;

// scheme.projection.max_rounds of a 3D scene that does not set it (docs/schemes.md,
// "Position projection"): rounds beyond the first are rare (the bin: 383 rounds on 378 steps)
constexpr int kDefaultProjectionRounds3d = 3;

// Relative paths inside a scene file are relative to the file's folder.
std::string resolve(const std::string& scene_path, const std::string& file) {
  const fs::path p(file);
  if (p.is_absolute()) return file;
  return (fs::path(scene_path).parent_path() / p).lexically_normal().string();
}

Matrix3 rotationFromRpy(const Vector3& rpy) {
  return (Eigen::AngleAxisd(rpy.z(), Vector3::UnitZ()) *
          Eigen::AngleAxisd(rpy.y(), Vector3::UnitY()) *
          Eigen::AngleAxisd(rpy.x(), Vector3::UnitX()))
      .toRotationMatrix();
}

// A frame whose outward axis (y for a half-plane, z for a half-space) is `normal`.
Matrix3 rotationWithNormal(const Vector3& normal, int dimension) {
  const Vector3 n = normal.normalized();
  Matrix3 r;
  if (dimension == 2) {
    r.col(0) = n.cross(Vector3::UnitZ());
    r.col(1) = n;
    r.col(2) = Vector3::UnitZ();
  } else {
    r = Eigen::Quaterniond::FromTwoVectors(Vector3::UnitZ(), n).toRotationMatrix();
  }
  return r;
}

}  // namespace

void SceneParser::parse(const YamlField& root) {
  root.requireMap();
  root.allowOnly({"dimension", "gravity", "materials", "contact", "bodies", "generators", "urdf",
                  "loads", "detection", "scheme", "time", "output"});
  SceneSpec& spec = out_.spec;
  spec.source = path_;
  if (!root.has("dimension")) root["dimension"].fail("is required (2 or 3)");
  const long dimension = root["dimension"].integer();
  if (dimension != 2 && dimension != 3) root["dimension"].fail("must be 2 or 3");
  spec.dimension = static_cast<int>(dimension);
  spec.gravity = spec.dimension == 2 ? Vector3(0, -9.81, 0) : Vector3(0, 0, -9.81);
  if (root.has("gravity")) spec.gravity = root["gravity"].vector(spec.dimension);
  if (root.has("materials")) parseMaterials(root["materials"]);
  if (root.has("generators")) parseGenerators(root["generators"]);
  if (root.has("contact")) parseContact(root["contact"]);
  if (root.has("bodies")) {
    const YamlField bodies = root["bodies"];
    bodies.requireSequence();
    explicit_from_ = spec.bodies.size();
    for (std::size_t i = 0; i < bodies.size(); ++i) spec.bodies.push_back(parseBody(bodies.at(i)));
  }
  if (root.has("urdf")) parseUrdfs(root["urdf"]);
  if (root.has("loads")) parseLoads(root["loads"]);
  if (root.has("detection")) parseDetection(root["detection"]);
  // 3D scenes project positions by default: VEL alone keeps what each impact leaves (h times
  // the landing speed, 20 % of a capsule's radius in the bin), POS turns overlaps into
  // separation speeds (docs/guide.md, "Choosing the normal law"; docs/schemes.md)
  if (spec.dimension == 3) out_.run.scheme.projection.max_rounds = kDefaultProjectionRounds3d;
  if (root.has("scheme")) parseScheme(root["scheme"]);
  if (root.has("time")) parseTime(root["time"]);
  if (root.has("output")) parseOutput(root["output"]);
  try {  // the run's step count, as `run` will count it
    stepCount(0.0, out_.run.t_end, out_.run.scheme.h);
  } catch (const InputError& e) {
    throw InputError(path_ + ": " + e.what());
  }
  // a powder bed is judged by its layer unless the file says how
  if (powder_layer_ && !out_.run.output.layer) out_.run.output.layer = powder_layer_;
  checkNames(root);
}

void SceneParser::parseMaterials(const YamlField& materials) {
  for (const std::string& name : materials.keys()) {
    const YamlField m = materials[name];
    if (!m.isMap() && !m.isNull()) m.fail("must be a map such as {density: 7800}");
    MaterialSpec spec{name, 0.0};
    if (m.isMap()) {
      m.allowOnly({"density"});
      spec.density = m.positive("density", 0.0);
    }
    addMaterial(spec, m);
  }
}

void SceneParser::addMaterial(const MaterialSpec& material, const YamlField& where) {
  for (const MaterialSpec& m : out_.spec.materials)
    if (m.name == material.name) where.fail("material '" + material.name + "' is defined twice");
  out_.spec.materials.push_back(material);
}

ContactLaw SceneParser::parseLaw(const YamlField& f, const ContactLaw& fallback) {
  ContactLaw law = fallback;
  law.friction = f.nonNegative("friction", law.friction);
  if (f.has("restitution")) {
    law.restitution = f["restitution"].number();
    if (!(law.restitution >= 0.0 && law.restitution <= 1.0))
      f["restitution"].fail("must be in [0, 1]");
  }
  law.rolling = f.nonNegative("rolling_resistance", law.rolling);
  law.adhesion_force = f.nonNegative("adhesion_force", law.adhesion_force);
  law.surface_energy = f.nonNegative("surface_energy", law.surface_energy);
  law.adhesion_range = f.nonNegative("adhesion_range", law.adhesion_range);
  return law;
}

void SceneParser::parseContact(const YamlField& contact) {
  contact.allowOnly({"friction", "restitution", "rolling_resistance", "adhesion_force",
                     "surface_energy", "adhesion_range", "pairs"});
  out_.spec.default_law = parseLaw(contact, out_.spec.default_law);
  if (!contact.has("pairs")) return;
  const YamlField pairs = contact["pairs"];
  pairs.requireSequence();
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const YamlField p = pairs.at(i);
    p.allowOnly({"materials", "friction", "restitution", "rolling_resistance", "adhesion_force",
                 "surface_energy", "adhesion_range"});
    const YamlField names = p["materials"];
    if (!names.isSequence() || names.size() != 2) names.fail("must name two materials");
    ContactLawSpec law{names.at(0).text(), names.at(1).text(), parseLaw(p, out_.spec.default_law)};
    for (std::size_t k = 0; k < 2; ++k) requireMaterial(names.at(k), names.at(k).text());
    // a second law for the same pair (in either order) would silently replace the first
    for (std::size_t j = 0; j < i; ++j) {
      const YamlField other = pairs.at(j)["materials"];
      const std::string a = other.at(0).text(), b = other.at(1).text();
      if ((a == law.material_a && b == law.material_b) ||
          (a == law.material_b && b == law.material_a))
        names.fail("this pair already has a law at " + pairs.path() + "[" + std::to_string(j) +
                   "]");
    }
    out_.spec.laws.push_back(law);
  }
}

void SceneParser::requireMaterial(const YamlField& where, const std::string& name) {
  for (const MaterialSpec& m : out_.spec.materials)
    if (m.name == name) return;
  where.fail("no such material (define it under materials)");
}

// a mesh's file and scale are kept in `spec` for export
Shape SceneParser::parseShape(const YamlField& body, const std::string& type, BodySpec& spec) {
  auto point2 = [&](const char* key) {
    const Vector3 v = body[key].vector(2);
    return Vector2(v.x(), v.y());
  };
  if (type == "disk") return Shape::disk(body["radius"].positive());
  if (type == "segment") {
    return Shape::segment(point2("start"), point2("end"), body.nonNegative("radius", 0.0));
  }
  if (type == "polygon") {
    const YamlField vertices = body["vertices"];
    vertices.requireSequence();
    std::vector<Vector2> points;
    for (std::size_t k = 0; k < vertices.size(); ++k) {
      const Vector3 v = vertices.at(k).vector(2);
      points.emplace_back(v.x(), v.y());
    }
    return Shape::polygon(points);
  }
  if (type == "half_plane") return Shape::halfPlane();
  if (type == "sphere") return Shape::sphere(body["radius"].positive());
  if (type == "box") {
    const Vector3 size = body["size"].vector(3);
    for (int k = 0; k < 3; ++k)
      if (!(size[k] > 0.0)) body["size"].at(k).fail("must be > 0");
    return Shape::box(size);
  }
  if (type == "cylinder")
    return Shape::cylinder(body["radius"].positive(), body["length"].positive());
  if (type == "capsule")
    return Shape::capsule(body["radius"].positive(), body["length"].positive());
  if (type == "plane") return Shape::halfSpace();
  if (type == "mesh") {
    Vector3 scale = Vector3::Ones();
    if (body.has("scale")) {
      scale = body["scale"].isSequence() ? body["scale"].vector(3)
                                         : Vector3::Constant(body["scale"].positive());
      for (int k = 0; k < 3; ++k)
        if (!(scale[k] > 0.0)) body["scale"].at(k).fail("must be > 0");
    }
    const std::string file = resolve(path_, body["file"].text());
    std::error_code error;
    if (fs::is_directory(file, error)) body["file"].fail("is a folder, not a mesh file");
    if (!fs::is_regular_file(file, error)) body["file"].fail("no such file (" + file + ")");
    spec.mesh_file = file;
    spec.mesh_scale = scale;
    std::shared_ptr<TriangleMesh> mesh;
    try {
      mesh = loadTriangleMesh(file, scale);
    } catch (const InputError& e) {
      throw InputError(path_ + ": " + body["file"].path() + ": " + e.what());
    }
    return body.boolean("convex", false) ? Shape::convexMesh(mesh) : Shape::triangleMesh(mesh);
  }
  body["shape"].fail(
      "must be one of disk, segment, polygon, half_plane (2D) or sphere, box, cylinder, "
      "capsule, mesh, plane (3D)");
}

BodySpec SceneParser::parseBody(const YamlField& f) {
  f.allowOnly({"name",
               "shape",
               "radius",
               "start",
               "end",
               "vertices",
               "size",
               "length",
               "file",
               "scale",
               "convex",
               "normal",
               "position",
               "angle",
               "rpy",
               "velocity",
               "angular_velocity",
               "material",
               "mass",
               "inertia",
               "fixed",
               "motion"});
  const int dim = out_.spec.dimension;
  BodySpec b;
  b.name = f.text("name", "body" + std::to_string(out_.spec.bodies.size()));
  if (!f.has("shape")) f["shape"].fail("is required");
  const std::string type = f["shape"].text();
  const bool planar_type =
      type == "disk" || type == "segment" || type == "polygon" || type == "half_plane";
  const bool known = planar_type || type == "sphere" || type == "box" || type == "cylinder" ||
                     type == "capsule" || type == "mesh" || type == "plane";
  if (known && planar_type != (dim == 2))
    f["shape"].fail(std::string("is not a shape of a ") + (dim == 2 ? "2D" : "3D") + " scene");
  b.shape = parseShape(f, type, b);
  if (f.has("material")) {
    b.material = f["material"].text();
    requireMaterial(f["material"], b.material);
  }
  if (f.has("position")) b.pose.translation = f["position"].vector(dim);
  if (dim == 2 && f.has("angle")) {
    b.written_angle = f["angle"].number();
    b.pose.rotation = Eigen::AngleAxisd(*b.written_angle, Vector3::UnitZ()).toRotationMatrix();
  }
  if (dim == 2 && f.has("rpy")) f["rpy"].fail("is for 3D scenes; use angle");
  if (dim == 3 && f.has("rpy")) {
    b.written_rpy = f["rpy"].vector(3);
    b.pose.rotation = rotationFromRpy(*b.written_rpy);
  }
  if (dim == 3 && f.has("angle")) f["angle"].fail("is for 2D scenes; use rpy");
  if (isUnbounded(b.shape)) {
    if (!f.has("normal")) f["normal"].fail("is required for a " + type);
    const Vector3 given = f["normal"].vector(dim);
    b.written_normal = given;
    const double largest = given.cwiseAbs().maxCoeff();
    if (!(largest > 0.0)) f["normal"].fail("must not be zero");
    // scaled before its norm is taken: the squares of 1e200 or 1e-200 overflow or vanish
    const Vector3 n = given / largest;
    b.pose.rotation = rotationWithNormal(n, dim);
  } else if (f.has("normal")) {
    f["normal"].fail("only half-planes and planes take a normal");
  }

  const bool fixed = f.boolean("fixed", false);
  if (fixed && f.has("motion")) f["motion"].fail("a fixed body cannot also move");
  b.kind = fixed ? BodySpec::Kind::Fixed
                 : (f.has("motion") ? BodySpec::Kind::Driven : BodySpec::Kind::Dynamic);
  if (isUnbounded(b.shape) && b.kind == BodySpec::Kind::Dynamic)
    f["shape"].fail("a " + type + " cannot be dynamic; add fixed: true");
  if (b.kind != BodySpec::Kind::Dynamic)
    for (const char* key : {"velocity", "angular_velocity", "mass", "inertia"})
      if (f.has(key)) f[key].fail("only dynamic bodies take it");

  if (f.has("velocity")) b.velocity = f["velocity"].vector(dim);
  if (f.has("angular_velocity")) {
    if (dim == 2)
      b.angular_velocity = Vector3(0, 0, f["angular_velocity"].number());
    else
      b.angular_velocity = f["angular_velocity"].vector(3);
  }
  if (f.has("mass")) b.mass = f["mass"].positive();
  if (f.has("inertia")) {
    const YamlField in = f["inertia"];
    Vector3 moments;
    if (dim == 2) {
      const double izz = in.positive();
      moments = Vector3(0.5 * izz, 0.5 * izz, izz);
    } else {
      moments = in.vector(3);
      for (int k = 0; k < 3; ++k)
        if (!(moments[k] > 0.0)) in.at(k).fail("must be > 0");
    }
    if (!b.mass) in.fail("needs a mass beside it");
    b.principal_inertia = moments;
  }
  if (b.kind == BodySpec::Kind::Dynamic && !b.mass && b.material.empty())
    f.fail("a dynamic body needs a material with a density, or a mass");
  if (b.kind == BodySpec::Kind::Dynamic && !b.mass) {
    for (const MaterialSpec& m : out_.spec.materials)
      if (m.name == b.material && !(m.density > 0.0))
        f["material"].fail("material '" + m.name + "' has no density; give the body a mass");
  }
  if (b.kind == BodySpec::Kind::Driven) b.motion = parseMotion(f["motion"]);
  return b;
}

MotionSpec SceneParser::parseMotion(const YamlField& f) {
  f.allowOnly({"type", "velocity", "angular_velocity", "times", "positions", "remove_at"});
  const int dim = out_.spec.dimension;
  MotionSpec m;
  const std::string type = f.text("type", "fixed");
  if (type == "fixed") {
    m.kind = MotionSpec::Kind::Fixed;
  } else if (type == "velocity") {
    m.kind = MotionSpec::Kind::Velocity;
    if (f.has("velocity")) m.linear_velocity = f["velocity"].vector(dim);
    if (f.has("angular_velocity"))
      m.angular_velocity = dim == 2 ? Vector3(0, 0, f["angular_velocity"].number())
                                    : f["angular_velocity"].vector(3);
  } else if (type == "keyframes") {
    m.kind = MotionSpec::Kind::Keyframes;
    m.times = f["times"].numbers();
    const YamlField positions = f["positions"];
    positions.requireSequence();
    if (positions.size() != m.times.size() || m.times.empty())
      positions.fail("must hold one position per time");
    for (std::size_t k = 0; k < positions.size(); ++k) {
      m.positions.push_back(positions.at(k).vector(dim));
      if (k > 0 && !(m.times[k] > m.times[k - 1])) f["times"].at(k).fail("times must increase");
    }
  } else {
    f["type"].fail("must be fixed, velocity or keyframes");
  }
  if (type != "velocity")
    for (const char* key : {"velocity", "angular_velocity"})
      if (f.has(key)) f[key].fail("only a velocity motion takes it");
  if (type != "keyframes")
    for (const char* key : {"times", "positions"})
      if (f.has(key)) f[key].fail("only a keyframes motion takes it");
  if (f.has("remove_at")) m.removal_time = f["remove_at"].number();
  return m;
}

void SceneParser::parseUrdfs(const YamlField& list) {
  list.requireSequence();
  for (std::size_t i = 0; i < list.size(); ++i) {
    const YamlField f = list.at(i);
    f.allowOnly({"file", "prefix", "floating", "position", "rpy", "joints", "velocities",
                 "material", "link_materials", "joint_springs", "package_paths", "missing_meshes",
                 "collision_meshes", "actuators"});
    UrdfSpec u;
    if (f.has("package_paths")) {
      const YamlField paths = f["package_paths"];
      paths.requireSequence();
      for (std::size_t k = 0; k < paths.size(); ++k) {
        const std::string folder = resolve(path_, paths.at(k).text());
        std::error_code error;
        if (!fs::is_directory(folder, error)) paths.at(k).fail("is not a folder (" + folder + ")");
        u.package_paths.push_back(folder);
      }
    }
    u.missing_meshes = f.choice("missing_meshes", MissingMeshes::Refuse);
    u.collision_meshes = f.choice("collision_meshes", CollisionMeshes::ConvexHull);
    u.file = resolve(path_, f["file"].text());
    if (!fs::is_regular_file(u.file)) f["file"].fail("no such file (" + u.file + ")");
    u.prefix = f.text("prefix", "");
    u.floating_base = f.boolean("floating", false);
    if (f.has("position")) u.base.translation = f["position"].vector(3);
    if (f.has("rpy")) {
      u.written_rpy = f["rpy"].vector(3);
      u.base.rotation = rotationFromRpy(*u.written_rpy);
    }
    auto joints = [&](const char* key, std::vector<std::pair<std::string, double>>& out) {
      if (!f.has(key)) return;
      for (const std::string& name : f[key].keys()) out.emplace_back(name, f[key][name].number());
    };
    joints("joints", u.joint_positions);
    joints("velocities", u.joint_velocities);
    if (f.has("material")) {
      u.material = f["material"].text();
      requireMaterial(f["material"], u.material);
    }
    if (f.has("link_materials")) {
      const YamlField links = f["link_materials"];
      links.requireMap();
      for (const std::string& link : links.keys()) {
        const std::string material = links[link].text();
        requireMaterial(links[link], material);
        u.link_materials.emplace_back(link, material);
      }
    }
    if (f.has("joint_springs")) {
      const YamlField springs = f["joint_springs"];
      springs.requireMap();
      for (const std::string& joint : springs.keys()) {
        const YamlField spring = springs[joint];
        spring.requireMap();
        spring.allowOnly({"stiffness", "rest"});
        if (!spring.has("stiffness")) spring["stiffness"].fail("is required");
        u.joint_springs.push_back(
            {joint, spring.nonNegative("stiffness", 0.0), spring.number("rest", 0.0)});
      }
    }
    if (f.has("actuators")) parseActuators(f["actuators"], u);
    out_.spec.urdfs.push_back(u);
  }
}

// a value (a constant) or {times: [...], values: [...]}, linear between the times
TimeTable SceneParser::timeTable(const YamlField& f) {
  if (!f.isMap()) return TimeTable::constant(f.number());
  f.allowOnly({"times", "values"});
  TimeTable table{f["times"].numbers(), f["values"].numbers()};
  if (table.values.empty()) f["values"].fail("must hold at least one value");
  try {
    checkTimeTable(table, f.path());
  } catch (const InputError& error) {
    throw InputError(f.file() + ": " + error.what());
  }
  return table;
}

// urdf[].actuators: {JOINT: {torque, kp, kd, position, velocity, max_torque}}
void SceneParser::parseActuators(const YamlField& map, UrdfSpec& u) {
  map.requireMap();
  for (const std::string& joint : map.keys()) {
    const YamlField f = map[joint];
    f.requireMap();
    f.allowOnly({"torque", "kp", "kd", "position", "velocity", "max_torque", "prescribed"});
    UrdfSpec::Actuator a;
    a.drive.joint = joint;
    if (f.has("torque")) a.drive.torque = timeTable(f["torque"]);
    a.drive.kp = f.nonNegative("kp", 0.0);
    a.drive.kd = f.nonNegative("kd", 0.0);
    if (f.has("position")) a.drive.position = timeTable(f["position"]);
    if (f.has("velocity")) a.drive.velocity = timeTable(f["velocity"]);
    if (f.has("prescribed")) {
      for (const char* other : {"torque", "kp", "kd", "position", "velocity"})
        if (f.has(other))
          f[other].fail("a prescribed joint follows its motion exactly: give prescribed alone");
      a.drive.prescribed = true;
      a.drive.position = timeTable(f["prescribed"]);
    }
    a.max_torque_given = f.has("max_torque");
    if (a.max_torque_given) a.drive.max_torque = f["max_torque"].positive();
    if (a.drive.kp > 0.0 && a.drive.position.empty())
      f["kp"].fail("needs a target: give position (a value or {times, values})");
    if (!a.drive.prescribed && a.drive.torque.empty() && !a.drive.servo())
      f.fail(
          "has neither a torque nor servo gains (kp, kd); a motor commanded from Python "
          "starts from torque: 0");
    u.actuators.push_back(a);
  }
}

// loads: a force and a torque on a dynamic body, each a constant plus a rate (a ramp)
void SceneParser::parseLoads(const YamlField& list) {
  list.requireSequence();
  const int dim = out_.spec.dimension;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const YamlField f = list.at(i);
    f.allowOnly({"body", "force", "force_rate", "torque", "torque_rate"});
    LoadSpec load;
    load.body = f["body"].text();
    bool found = false;
    for (const BodySpec& b : out_.spec.bodies)
      found = found || (b.name == load.body && b.kind == BodySpec::Kind::Dynamic);
    if (!found) f["body"].fail("no dynamic body of this name under bodies");
    if (f.has("force")) load.force = f["force"].vector(dim);
    if (f.has("force_rate")) load.force_rate = f["force_rate"].vector(dim);
    auto torque = [&](const char* key, Vector3& out) {
      if (!f.has(key)) return;
      out = dim == 2 ? Vector3(0, 0, f[key].number()) : f[key].vector(3);
    };
    torque("torque", load.torque);
    torque("torque_rate", load.torque_rate);
    out_.spec.loads.push_back(load);
  }
}

void SceneParser::checkNames(const YamlField& root) {
  std::set<std::string> seen;
  const auto& bodies = out_.spec.bodies;
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    if (seen.insert(bodies[i].name).second) continue;
    if (i >= explicit_from_)
      root["bodies"].at(i - explicit_from_)["name"].fail("another body has this name");
    root["generators"].fail("two generated bodies are named '" + bodies[i].name + "'");
  }
}

namespace {
// A parsed document with the settings files' entries and then the overrides applied, parsed
// into a scene.
SceneFile sceneFrom(YAML::Node root, const std::string& path,
                    const std::vector<std::string>& overrides,
                    const std::vector<std::string>& settings_files, long max_count) {
  for (const std::string& settings : settings_files)
    for (const FieldOverride& o : loadOverrideFile(settings)) applyOverride(root, o, path);
  for (const std::string& o : overrides) applyOverride(root, o, path);
  SceneFile scene;
  scene.path = path;
  SceneParser(path, scene, std::min(max_count, kMaxGeneratorCount)).parse(YamlField(root, path));
  return scene;
}
}  // namespace

SceneFile loadSceneFile(const std::string& path, const std::vector<std::string>& overrides,
                        const std::vector<std::string>& settings_files) {
  return sceneFrom(loadYamlFile(path), path, overrides, settings_files, kMaxGeneratorCount);
}

SceneFile loadSceneText(const std::string& text, const std::string& path,
                        const std::vector<std::string>& overrides,
                        const std::vector<std::string>& settings_files) {
  return sceneFrom(parseYamlText(text, path), path, overrides, settings_files, kMaxGeneratorCount);
}

SceneFile loadSceneText(const std::string& text, const std::string& path, long max_count) {
  return sceneFrom(parseYamlText(text, path), path, {}, {}, max_count);
}

Scene buildSceneFile(const SceneFile& file) {
  try {
    return buildScene(file.spec);
  } catch (const InputError& e) {
    const std::string message = e.what();
    if (message.rfind(file.path + ":", 0) == 0) throw;
    throw InputError(file.path + ": " + message);
  }
}

}  // namespace sweep
