// `sweep export`: a scene written back as an explicit file (every body listed, no generators)
// that builds to the same model, state and settings, to the bit.
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>

#include "apps/sweep/scene_file.hpp"
#include "apps/sweep/signals.hpp"
#include "framework/error.hpp"

namespace sweep {

namespace fs = std::filesystem;

namespace {

void emitVector(YAML::Emitter& out, const Vector3& v, int dimension) {
  out << YAML::Flow << YAML::BeginSeq;
  for (int k = 0; k < dimension; ++k) out << v[k];
  out << YAML::EndSeq;
}

const char* shapeKeyword(ShapeType type) {
  switch (type) {
    case ShapeType::Disk:
      return "disk";
    case ShapeType::Segment:
      return "segment";
    case ShapeType::Polygon:
      return "polygon";
    case ShapeType::HalfPlane:
      return "half_plane";
    case ShapeType::Sphere:
      return "sphere";
    case ShapeType::Box:
      return "box";
    case ShapeType::Cylinder:
      return "cylinder";
    case ShapeType::Capsule:
      return "capsule";
    case ShapeType::HalfSpace:
      return "plane";
    default:
      return nullptr;
  }
}

// the adhesion keys a law sets (all zero: none, as a scene without adhesion writes them)
void emitAdhesion(YAML::Emitter& out, const ContactLaw& law) {
  const std::pair<const char*, double> keys[] = {{"adhesion_force", law.adhesion_force},
                                                 {"surface_energy", law.surface_energy},
                                                 {"adhesion_range", law.adhesion_range}};
  for (const auto& [key, value] : keys)
    if (value > 0.0) out << YAML::Key << key << YAML::Value << value;
}

// the keys parseSolver reads, in its order (stage: scheme B's, which choose their solver)
void emitSolver(YAML::Emitter& out, const char* key, const SolverSettings& s, bool stage) {
  out << YAML::Key << key << YAML::Value << YAML::Flow << YAML::BeginMap;
  if (stage) out << YAML::Key << "solver" << YAML::Value << enumName(s.solver);
  out << YAML::Key << "max_iterations" << YAML::Value << s.max_iterations;
  out << YAML::Key << "tolerance" << YAML::Value << s.tolerance;
  out << YAML::Key << "residual_check_interval" << YAML::Value << s.residual_check_interval;
  out << YAML::Key << "relaxation" << YAML::Value << s.relaxation;
  out << YAML::Key << "shuffle" << YAML::Value << s.shuffle;
  out << YAML::Key << "seed" << YAML::Value << s.seed;
  out << YAML::Key << "acceleration" << YAML::Value << enumName(s.acceleration);
  if (!stage) {
    out << YAML::Key << "local_solver" << YAML::Value << enumName(s.local_solver_3d);
    out << YAML::Key << "parallel_rows" << YAML::Value << s.parallel_rows;
  }
  out << YAML::EndMap;
}

// The orientation as the file wrote it where it did (the same bits back), else from the
// rotation: a generator's bodies.
void emitOrientation(YAML::Emitter& out, const BodySpec& b, int dim) {
  const Matrix3& r = b.pose.rotation;
  if (isUnbounded(b.shape)) {
    out << YAML::Key << "normal" << YAML::Value;
    emitVector(
        out,
        b.written_normal ? *b.written_normal : (dim == 2 ? Vector3(r.col(1)) : Vector3(r.col(2))),
        dim);
  } else if (dim == 2) {
    const double angle = b.written_angle ? *b.written_angle : std::atan2(r(1, 0), r(0, 0));
    if (b.written_angle || angle != 0.0) out << YAML::Key << "angle" << YAML::Value << angle;
  } else if (b.written_rpy) {
    out << YAML::Key << "rpy" << YAML::Value;
    emitVector(out, *b.written_rpy, 3);
  } else if (!r.isIdentity(0.0)) {
    const Vector3 ypr = r.eulerAngles(2, 1, 0);
    out << YAML::Key << "rpy" << YAML::Value;
    emitVector(out, Vector3(ypr.z(), ypr.y(), ypr.x()), 3);
  }
}

// a table as its constant, or as {times, values}
void emitTimeTable(YAML::Emitter& out, const char* key, const TimeTable& table) {
  if (table.empty()) return;
  out << YAML::Key << key << YAML::Value;
  if (table.values.size() == 1) {
    out << table.values.front();
    return;
  }
  out << YAML::Flow << YAML::BeginMap << YAML::Key << "times" << YAML::Value << YAML::Flow
      << table.times << YAML::Key << "values" << YAML::Value << YAML::Flow << table.values
      << YAML::EndMap;
}

void emitActuator(YAML::Emitter& out, const UrdfSpec::Actuator& a) {
  const JointActuator& d = a.drive;
  out << YAML::Key << d.joint << YAML::Value << YAML::Flow << YAML::BeginMap;
  if (d.prescribed) emitTimeTable(out, "prescribed", d.position);
  emitTimeTable(out, "torque", d.torque);
  if (d.kp > 0.0) out << YAML::Key << "kp" << YAML::Value << d.kp;
  if (d.kd > 0.0) out << YAML::Key << "kd" << YAML::Value << d.kd;
  if (!d.prescribed) emitTimeTable(out, "position", d.position);
  emitTimeTable(out, "velocity", d.velocity);
  if (a.max_torque_given) out << YAML::Key << "max_torque" << YAML::Value << d.max_torque;
  out << YAML::EndMap;
}

void emitUrdf(YAML::Emitter& out, const UrdfSpec& u, const std::string& file,
              const std::function<std::string(const std::string&)>& fromExport) {
  out << YAML::BeginMap;
  out << YAML::Key << "file" << YAML::Value << file;
  if (!u.prefix.empty()) out << YAML::Key << "prefix" << YAML::Value << u.prefix;
  if (!u.package_paths.empty()) {
    out << YAML::Key << "package_paths" << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (const std::string& folder : u.package_paths) out << fromExport(folder);
    out << YAML::EndSeq;
  }
  out << YAML::Key << "missing_meshes" << YAML::Value << enumName(u.missing_meshes);
  out << YAML::Key << "collision_meshes" << YAML::Value << enumName(u.collision_meshes);
  out << YAML::Key << "floating" << YAML::Value << u.floating_base;
  out << YAML::Key << "position" << YAML::Value;
  emitVector(out, u.base.translation, 3);
  if (u.written_rpy || !u.base.rotation.isIdentity(0.0)) {
    const Vector3 ypr = u.base.rotation.eulerAngles(2, 1, 0);
    out << YAML::Key << "rpy" << YAML::Value;
    emitVector(out, u.written_rpy ? *u.written_rpy : Vector3(ypr.z(), ypr.y(), ypr.x()), 3);
  }
  for (const auto& [key, values] :
       {std::pair<const char*, const std::vector<std::pair<std::string, double>>&>{
            "joints", u.joint_positions},
        {"velocities", u.joint_velocities}}) {
    if (values.empty()) continue;
    out << YAML::Key << key << YAML::Value << YAML::Flow << YAML::BeginMap;
    for (const auto& [joint, value] : values) out << YAML::Key << joint << YAML::Value << value;
    out << YAML::EndMap;
  }
  if (!u.material.empty()) out << YAML::Key << "material" << YAML::Value << u.material;
  if (!u.link_materials.empty()) {
    out << YAML::Key << "link_materials" << YAML::Value << YAML::Flow << YAML::BeginMap;
    for (const auto& [link, material] : u.link_materials)
      out << YAML::Key << link << YAML::Value << material;
    out << YAML::EndMap;
  }
  if (!u.joint_springs.empty()) {
    out << YAML::Key << "joint_springs" << YAML::Value << YAML::BeginMap;
    for (const UrdfSpec::JointSpring& spring : u.joint_springs)
      out << YAML::Key << spring.joint << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key
          << "stiffness" << YAML::Value << spring.stiffness << YAML::Key << "rest" << YAML::Value
          << spring.rest << YAML::EndMap;
    out << YAML::EndMap;
  }
  if (!u.actuators.empty()) {
    out << YAML::Key << "actuators" << YAML::Value << YAML::BeginMap;
    for (const UrdfSpec::Actuator& a : u.actuators) emitActuator(out, a);
    out << YAML::EndMap;
  }
  out << YAML::EndMap;
}

void emitDetection(YAML::Emitter& out, const SceneSpec& spec) {
  const DetectionSettings& d = spec.detection;
  out << YAML::Key << "detection" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "path" << YAML::Value << enumName(d.path);
  out << YAML::Key << "speed_factor" << YAML::Value << d.speed_factor;
  out << YAML::Key << "margin_rule" << YAML::Value << enumName(d.margin_rule);
  out << YAML::Key << "verify_margin" << YAML::Value << d.verify_margin;
  if (d.floor >= 0.0) out << YAML::Key << "margin" << YAML::Value << d.floor;  // < 0: automatic
  out << YAML::Key << "self_collision" << YAML::Value << d.self_collision;
  out << YAML::Key << "max_initial_overlap" << YAML::Value << spec.max_initial_overlap;
  if (d.periodic.enabled()) {
    const char axis[] = {static_cast<char>('x' + d.periodic.axis), '\0'};
    out << YAML::Key << "periodic" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key
        << "axis" << YAML::Value << axis << YAML::Key << "low" << YAML::Value << d.periodic.low
        << YAML::Key << "high" << YAML::Value << d.periodic.high << YAML::EndMap;
  }
  out << YAML::EndMap;
}

void emitOutput(YAML::Emitter& out, const OutputSettings& o) {
  out << YAML::Key << "output" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "stats" << YAML::Value << o.stats;
  out << YAML::Key << "timings" << YAML::Value << o.timings;
  out << YAML::Key << "vtk_every" << YAML::Value << o.vtk_every;
  out << YAML::Key << "vtk_interval" << YAML::Value << o.vtk_interval;
  if (o.layer) {
    const LayerWindow& w = *o.layer;
    out << YAML::Key << "layer" << YAML::Value << YAML::Flow << YAML::BeginMap;
    for (const auto& [key, value] : {std::pair<const char*, double>{"x_min", w.x_min},
                                     {"x_max", w.x_max},
                                     {"z_min", w.z_min},
                                     {"z_max", w.z_max},
                                     {"plate", w.plate},
                                     {"gap", w.gap},
                                     {"cell", w.cell},
                                     {"resolution", w.resolution}})
      out << YAML::Key << key << YAML::Value << value;
    out << YAML::EndMap;
  }
  out << YAML::EndMap;
}

}  // namespace

void writeSceneFile(const SceneFile& scene, const std::string& path) {
  const SceneSpec& spec = scene.spec;
  const int dim = spec.dimension;
  const fs::path folder = fs::absolute(fs::path(path)).lexically_normal().parent_path();
  // file names as seen from the exported file, which resolves them against its own folder:
  // relative where the two share a folder (a tree moved whole still loads), else absolute
  const auto fromExport = [&](const std::string& file) {
    const fs::path absolute = fs::absolute(file).lexically_normal();
    int shared = 0;
    for (auto a = absolute.begin(), b = folder.begin();
         a != absolute.end() && b != folder.end() && *a == *b; ++a, ++b)
      ++shared;
    const fs::path relative = absolute.lexically_relative(folder);
    return (shared > 1 && !relative.empty() ? relative : absolute).generic_string();
  };
  YAML::Emitter out;
  out.SetDoublePrecision(17);
  out << YAML::BeginMap;
  out << YAML::Key << "dimension" << YAML::Value << dim;
  out << YAML::Key << "gravity" << YAML::Value;
  emitVector(out, spec.gravity, dim);
  out << YAML::Key << "materials" << YAML::Value << YAML::BeginMap;
  for (const MaterialSpec& m : spec.materials) {
    out << YAML::Key << m.name << YAML::Value << YAML::Flow << YAML::BeginMap;
    if (m.density > 0.0) out << YAML::Key << "density" << YAML::Value << m.density;
    out << YAML::EndMap;
  }
  out << YAML::EndMap;
  out << YAML::Key << "contact" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "friction" << YAML::Value << spec.default_law.friction;
  out << YAML::Key << "restitution" << YAML::Value << spec.default_law.restitution;
  if (spec.default_law.rolling > 0.0)
    out << YAML::Key << "rolling_resistance" << YAML::Value << spec.default_law.rolling;
  emitAdhesion(out, spec.default_law);
  out << YAML::Key << "pairs" << YAML::Value << YAML::BeginSeq;
  for (const ContactLawSpec& l : spec.laws) {
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "materials" << YAML::Value << YAML::Flow
        << YAML::BeginSeq << l.material_a << l.material_b << YAML::EndSeq;
    out << YAML::Key << "friction" << YAML::Value << l.law.friction;
    out << YAML::Key << "restitution" << YAML::Value << l.law.restitution;
    if (l.law.rolling > 0.0)
      out << YAML::Key << "rolling_resistance" << YAML::Value << l.law.rolling;
    emitAdhesion(out, l.law);
    out << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::EndMap;

  out << YAML::Key << "bodies" << YAML::Value << YAML::BeginSeq;
  for (const BodySpec& b : spec.bodies) {
    const bool mesh =
        b.shape.type == ShapeType::ConvexMesh || b.shape.type == ShapeType::TriangleMesh;
    const char* keyword = mesh ? "mesh" : shapeKeyword(b.shape.type);
    if (keyword == nullptr || (mesh && b.mesh_file.empty()))
      throw InputError(path + ": body '" + b.name + "': a " + shapeTypeName(b.shape.type) +
                       " made in code has no file to export");
    out << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << "name" << YAML::Value << b.name;
    out << YAML::Key << "shape" << YAML::Value << keyword;
    const Shape& s = b.shape;
    switch (s.type) {
      case ShapeType::Segment:
        out << YAML::Key << "start" << YAML::Value;
        emitVector(out, s.segment_start, 2);
        out << YAML::Key << "end" << YAML::Value;
        emitVector(out, s.segment_end, 2);
        if (s.radius > 0.0) out << YAML::Key << "radius" << YAML::Value << s.radius;
        break;
      case ShapeType::Polygon:
        out << YAML::Key << "vertices" << YAML::Value << YAML::Flow << YAML::BeginSeq;
        for (const Vector3& v : s.vertices) emitVector(out, v, 2);
        out << YAML::EndSeq;
        break;
      case ShapeType::Box:
        out << YAML::Key << "size" << YAML::Value;
        emitVector(out, 2.0 * s.half_extents, 3);
        break;
      case ShapeType::Cylinder:
      case ShapeType::Capsule:
        out << YAML::Key << "radius" << YAML::Value << s.radius;
        out << YAML::Key << "length" << YAML::Value << s.length;
        break;
      case ShapeType::Disk:
      case ShapeType::Sphere:
        out << YAML::Key << "radius" << YAML::Value << s.radius;
        break;
      case ShapeType::ConvexMesh:
      case ShapeType::TriangleMesh:
        out << YAML::Key << "file" << YAML::Value << fromExport(b.mesh_file);
        out << YAML::Key << "scale" << YAML::Value;
        emitVector(out, b.mesh_scale, 3);
        out << YAML::Key << "convex" << YAML::Value << (s.type == ShapeType::ConvexMesh);
        break;
      default:
        break;
    }
    if (!b.material.empty()) out << YAML::Key << "material" << YAML::Value << b.material;
    out << YAML::Key << "position" << YAML::Value;
    emitVector(out, b.pose.translation, dim);
    emitOrientation(out, b, dim);
    if (b.kind == BodySpec::Kind::Fixed) out << YAML::Key << "fixed" << YAML::Value << true;
    if (b.kind == BodySpec::Kind::Dynamic) {
      if (!b.velocity.isZero(0.0)) {
        out << YAML::Key << "velocity" << YAML::Value;
        emitVector(out, b.velocity, dim);
      }
      if (b.mass) out << YAML::Key << "mass" << YAML::Value << *b.mass;
      if (b.principal_inertia) {
        out << YAML::Key << "inertia" << YAML::Value;
        if (dim == 2)
          out << b.principal_inertia->z();
        else
          emitVector(out, *b.principal_inertia, 3);
      }
      if (!b.angular_velocity.isZero(0.0)) {
        out << YAML::Key << "angular_velocity" << YAML::Value;
        if (dim == 2)
          out << b.angular_velocity.z();
        else
          emitVector(out, b.angular_velocity, 3);
      }
    }
    if (b.kind == BodySpec::Kind::Driven) {
      const MotionSpec& m = b.motion;
      out << YAML::Key << "motion" << YAML::Value << YAML::Flow << YAML::BeginMap;
      const char* kind = m.kind == MotionSpec::Kind::Fixed      ? "fixed"
                         : m.kind == MotionSpec::Kind::Velocity ? "velocity"
                                                                : "keyframes";
      out << YAML::Key << "type" << YAML::Value << kind;
      if (m.kind == MotionSpec::Kind::Velocity) {
        out << YAML::Key << "velocity" << YAML::Value;
        emitVector(out, m.linear_velocity, dim);
        out << YAML::Key << "angular_velocity" << YAML::Value;
        if (dim == 2)
          out << m.angular_velocity.z();
        else
          emitVector(out, m.angular_velocity, 3);
      }
      if (m.kind == MotionSpec::Kind::Keyframes) {
        out << YAML::Key << "times" << YAML::Value << YAML::Flow << m.times;
        out << YAML::Key << "positions" << YAML::Value << YAML::Flow << YAML::BeginSeq;
        for (const Vector3& p : m.positions) emitVector(out, p, dim);
        out << YAML::EndSeq;
      }
      if (std::isfinite(m.removal_time))
        out << YAML::Key << "remove_at" << YAML::Value << m.removal_time;
      out << YAML::EndMap;
    }
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;

  if (!spec.urdfs.empty()) {
    out << YAML::Key << "urdf" << YAML::Value << YAML::BeginSeq;
    for (const UrdfSpec& u : spec.urdfs) emitUrdf(out, u, fromExport(u.file), fromExport);
    out << YAML::EndSeq;
  }

  if (!spec.loads.empty()) {
    out << YAML::Key << "loads" << YAML::Value << YAML::BeginSeq;
    for (const LoadSpec& l : spec.loads) {
      out << YAML::Flow << YAML::BeginMap << YAML::Key << "body" << YAML::Value << l.body;
      out << YAML::Key << "force" << YAML::Value;
      emitVector(out, l.force, dim);
      out << YAML::Key << "force_rate" << YAML::Value;
      emitVector(out, l.force_rate, dim);
      for (const auto& [key, torque] : {std::pair<const char*, const Vector3&>{"torque", l.torque},
                                        {"torque_rate", l.torque_rate}}) {
        out << YAML::Key << key << YAML::Value;
        if (dim == 2)
          out << torque.z();
        else
          emitVector(out, torque, 3);
      }
      out << YAML::EndMap;
    }
    out << YAML::EndSeq;
  }

  const SchemeSettings& s = scene.run.scheme;
  out << YAML::Key << "scheme" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "name" << YAML::Value << enumName(s.scheme);
  out << YAML::Key << "normal_law" << YAML::Value << enumName(s.normal_law);
  out << YAML::Key << "tangents" << YAML::Value << enumName(s.friction.tangents);
  out << YAML::Key << "threshold" << YAML::Value << enumName(s.friction.threshold);
  out << YAML::Key << "threshold_updates" << YAML::Value << s.friction.threshold_updates;
  out << YAML::Key << "open_contacts" << YAML::Value << enumName(s.friction.open_contacts);
  emitSolver(out, "coulomb", s.coulomb, false);
  emitSolver(out, "normal_stage", s.normal_stage, true);
  emitSolver(out, "friction_stage", s.friction_stage, true);
  out << YAML::Key << "screening" << YAML::Value << s.screening;
  out << YAML::Key << "screening_rounds" << YAML::Value << s.screening_rounds;
  if (s.screening_gap >= 0.0) out << YAML::Key << "screening_gap" << YAML::Value << s.screening_gap;
  out << YAML::Key << "projection" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key
      << "max_rounds" << YAML::Value << s.projection.max_rounds << YAML::Key << "tolerance"
      << YAML::Value << s.projection.tolerance << YAML::EndMap;
  out << YAML::Key << "threads" << YAML::Value << s.threads;
  out << YAML::EndMap;
  out << YAML::Key << "time" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "step"
      << YAML::Value << s.h << YAML::Key << "end" << YAML::Value << scene.run.t_end << YAML::EndMap;
  emitDetection(out, spec);
  emitOutput(out, scene.run.output);
  out << YAML::EndMap;
  if (!out.good()) throw std::runtime_error("scene export: " + out.GetLastError());

  const PartialFile registered(path + ".partial");
  const std::string& partial = registered.path();
  {
    std::ofstream file(partial);
    file << "# explicit scene exported by `sweep export` from " << scene.path << "\n"
         << out.c_str() << "\n";
    if (!file.good()) throw std::runtime_error(path + ": cannot write the file");
  }
  fs::rename(partial, path);
}

}  // namespace sweep
