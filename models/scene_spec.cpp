#include "models/scene_spec.hpp"

#include <cmath>
#include <map>
#include <random>
#include <sstream>
#include <tuple>
#include <unordered_map>

#include <Eigen/Eigenvalues>

#include "contact/detection.hpp"
#include "framework/error.hpp"
#include "framework/kinematics.hpp"
#include "framework/urdf_import.hpp"
#include "models/rigid_bodies.hpp"

namespace sweep {

namespace {

std::string owner(const BodySpec& body) {
  return "body '" + body.name + "'";
}

// Mass properties per unit density: area or volume, centroid, and the principal moments
// about the centroid in shape axes (2D: only the z moment matters; x and y are set to half
// of it so the 3x3 block stays positive definite).
struct UnitInertia {
  double measure = 0.0;
  Vector3 centroid = Vector3::Zero();
  Vector3 moments = Vector3::Zero();
};

UnitInertia planarMoment(double area, const Vector3& centroid, double polar_moment) {
  return {area, centroid, Vector3(0.5 * polar_moment, 0.5 * polar_moment, polar_moment)};
}

UnitInertia unitInertia(const BodySpec& body) {
  const Shape& s = body.shape;
  const double r = s.radius;
  switch (s.type) {
    case ShapeType::Disk: {
      const double area = M_PI * r * r;
      return planarMoment(area, Vector3::Zero(), 0.5 * area * r * r);
    }
    case ShapeType::Polygon: {
      // shoelace sums for area, first and second moments about the body origin
      double area = 0.0, polar = 0.0;
      Vector3 first = Vector3::Zero();
      const std::size_t n = s.vertices.size();
      for (std::size_t i = 0; i < n; ++i) {
        const Vector3& a = s.vertices[i];
        const Vector3& b = s.vertices[(i + 1) % n];
        const double cross = a.x() * b.y() - b.x() * a.y();
        area += 0.5 * cross;
        first.x() += cross * (a.x() + b.x()) / 6.0;
        first.y() += cross * (a.y() + b.y()) / 6.0;
        polar += cross *
                 (a.x() * a.x() + a.x() * b.x() + b.x() * b.x() + a.y() * a.y() + a.y() * b.y() +
                  b.y() * b.y()) /
                 12.0;
      }
      const Vector3 centroid = first / area;
      return planarMoment(area, centroid, polar - area * centroid.squaredNorm());
    }
    case ShapeType::Segment: {
      // a rectangle L x 2r between two half-disks
      const double length = (s.segment_end - s.segment_start).norm();
      const double rect = 2.0 * r * length;
      const double half_disk = 0.5 * M_PI * r * r;
      const double offset = 4.0 * r / (3.0 * M_PI);  // half-disk centroid from its edge
      const double about_edge = 0.5 * half_disk * r * r;
      const double about_own = about_edge - half_disk * offset * offset;
      const double arm = 0.5 * length + offset;
      const double polar =
          rect * (length * length + 4.0 * r * r) / 12.0 + 2.0 * (about_own + half_disk * arm * arm);
      return planarMoment(rect + 2.0 * half_disk, 0.5 * (s.segment_start + s.segment_end), polar);
    }
    case ShapeType::Sphere: {
      const double volume = 4.0 / 3.0 * M_PI * r * r * r;
      return {volume, Vector3::Zero(), Vector3::Constant(0.4 * volume * r * r)};
    }
    case ShapeType::Box: {
      const Vector3 size = 2.0 * s.half_extents;
      const double volume = size.prod();
      const Vector3 s2 = size.cwiseProduct(size);
      return {volume, Vector3::Zero(),
              volume / 12.0 * Vector3(s2.y() + s2.z(), s2.x() + s2.z(), s2.x() + s2.y())};
    }
    case ShapeType::Cylinder: {
      const double volume = M_PI * r * r * s.length;
      const double side = volume * (3.0 * r * r + s.length * s.length) / 12.0;
      return {volume, Vector3::Zero(), Vector3(side, side, 0.5 * volume * r * r)};
    }
    case ShapeType::Capsule: {
      const double l = s.length;
      const double cylinder = M_PI * r * r * l;
      const double caps = 4.0 / 3.0 * M_PI * r * r * r;
      const double side = cylinder * (l * l / 12.0 + r * r / 4.0) +
                          caps * (0.4 * r * r + l * l / 4.0 + 3.0 * l * r / 8.0);
      return {cylinder + caps, Vector3::Zero(),
              Vector3(side, side, 0.5 * cylinder * r * r + 0.4 * caps * r * r)};
    }
    default:
      return {};
  }
}

}  // namespace

std::vector<double> sampleRadii(const RadiusDistribution& d, int count, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<double> radii(std::max(count, 0), d.a);
  if (d.kind == RadiusDistribution::Kind::Normal) {
    std::normal_distribution<double> normal(0.0, 1.0);
    for (double& r : radii) {
      double z = normal(rng);
      while (std::abs(z) > 3.0) z = normal(rng);
      r = d.a + d.b * z;
    }
  } else if (d.kind == RadiusDistribution::Kind::Uniform) {
    std::uniform_real_distribution<double> uniform(d.a, d.b);
    for (double& r : radii) r = uniform(rng);
  }
  return radii;
}

Inertia bodyInertia(const BodySpec& body, double density, int dimension) {
  const UnitInertia unit = unitInertia(body);
  Inertia inertia;
  inertia.com = unit.centroid;
  if (body.mass && body.principal_inertia) {
    inertia.mass = *body.mass;
    inertia.inertia_com = body.principal_inertia->asDiagonal();
  } else if (unit.measure > 0.0) {
    inertia.mass = body.mass ? *body.mass : density * unit.measure;
    inertia.inertia_com = (inertia.mass / unit.measure * unit.moments).asDiagonal();
  } else {
    throw InputError(owner(body) + ": a " + shapeTypeName(body.shape.type) +
                     (dimension == 2 ? " has no area" : " has no closed-form volume") +
                     "; give both mass and inertia");
  }
  if (!(inertia.mass > 0.0) || !std::isfinite(inertia.mass))
    throw InputError(owner(body) + ": mass must be > 0, got " + formatValue(inertia.mass) +
                     (body.mass ? "" : " (density x size)"));
  const Vector3 moments = inertia.inertia_com.diagonal();
  if (!(moments.minCoeff() > 0.0) || !moments.allFinite())
    throw InputError(owner(body) + ": inertia must be > 0 and finite, got [" +
                     formatValue(moments.x()) + ", " + formatValue(moments.y()) + ", " +
                     formatValue(moments.z()) + "]");
  // a real mass distribution has each principal moment at most the sum of the other two
  if (dimension == 3 && body.principal_inertia)
    for (int k = 0; k < 3; ++k)
      if (moments[k] > (moments[(k + 1) % 3] + moments[(k + 2) % 3]) * (1.0 + 1e-9))
        throw InputError(owner(body) + ": inertia [" + formatValue(moments.x()) + ", " +
                         formatValue(moments.y()) + ", " + formatValue(moments.z()) +
                         "]: the moment " + formatValue(moments[k]) +
                         " exceeds the sum of the other two, which no mass distribution has");
  // The model refuses a mass matrix whose pivots span more than 12 orders of magnitude as
  // singular; said here, the message can name the body and its values (a mass of 1e-300 kg
  // with an inertia of 1e-5, an inertia of 1e308 with a mass of 1).
  const double mass = inertia.mass;
  const double low =
      dimension == 2 ? std::min(mass, moments.z()) : std::min(mass, moments.minCoeff());
  const double high =
      dimension == 2 ? std::max(mass, moments.z()) : std::max(mass, moments.maxCoeff());
  if (low < 1e-12 * high)
    throw InputError(owner(body) + ": mass " + formatValue(mass) + " kg and inertia " +
                     (dimension == 2
                          ? formatValue(moments.z())
                          : "[" + formatValue(moments.x()) + ", " + formatValue(moments.y()) +
                                ", " + formatValue(moments.z()) + "]") +
                     " kg m^2 differ by more than 12 orders of magnitude: the mass matrix would "
                     "be singular in double precision (check the units)");
  return inertia;
}

void rejectOverlaps(const Scene& scene, double t, const VectorX& q, const VectorX& v,
                    double max_overlap, double max_relative_overlap, const std::string& where,
                    const std::string& when) {
  Data data(scene.model);
  forwardKinematics(scene.model, data, q, v);
  ContactData cdata(scene.model, scene.cmodel);
  detectContacts(scene.model, data, scene.cmodel, cdata, t, 0.0);
  for (const Contact& c : cdata.contacts) {
    const Geometry& a = scene.cmodel.geometries[c.key.geometry_a];
    const Geometry& b = scene.cmodel.geometries[c.key.geometry_b];
    const double size = std::min(boundingRadius(a.shape), boundingRadius(b.shape));
    const double allowed = std::max(max_overlap, max_relative_overlap * size);
    if (-c.gap <= allowed) continue;
    throw InputError(where + ": '" + a.name + "' and '" + b.name + "' overlap by " +
                     formatValue(-c.gap) + " m " + when + ", more than " + formatValue(allowed) +
                     (allowed == max_overlap
                          ? " m (detection.max_initial_overlap): move them apart"
                          : " m (" + formatValue(max_relative_overlap) +
                                " of the smaller body's bounding radius): move them apart"));
  }
}

namespace {

// The model's body moved by joint `joint` of URDF u, or InputError naming the scene's field and
// the file that lacks it (Model::jointIndex knows neither).
int urdfJointBody(const SceneSpec& spec, const Model& model, std::size_t u, const char* field,
                  const std::string& joint) {
  const UrdfSpec& urdf = spec.urdfs[u];
  for (std::size_t i = 0; i < model.bodies.size(); ++i)
    if (model.bodies[i].joint_name == urdf.prefix + joint) return static_cast<int>(i);
  throw InputError(spec.source + ": urdf[" + std::to_string(u) + "]." + field + "." + joint + ": " +
                   urdf.file + " has no joint named '" + joint + "'");
}

// The loads as generalized forces. A planar body's velocities are (x, y rates of its origin,
// spin), a free body's (its origin's world velocity, body-frame angular velocity), so a force
// at the origin enters as it is and a torque as its z (2D) or its body-frame components.
std::function<void(double, const VectorX&, const VectorX&, VectorX&)> sceneLoads(
    const SceneSpec& spec, const Model& model) {
  struct Spring {
    int q_index, v_index;
    double stiffness, rest;
  };
  std::vector<Spring> springs;
  for (std::size_t u = 0; u < spec.urdfs.size(); ++u)
    for (const UrdfSpec::JointSpring& s : spec.urdfs[u].joint_springs) {
      const Body& b = model.bodies[urdfJointBody(spec, model, u, "joint_springs", s.joint)];
      if (b.joint.nv() != 1)
        throw InputError(spec.source + ": urdf[" + std::to_string(u) + "].joint_springs." +
                         s.joint + ": the joint has " + std::to_string(b.joint.nv()) +
                         " velocities; springs act on 1-dof joints");
      springs.push_back({b.q_index, b.v_index, s.stiffness, s.rest});
    }
  if (spec.loads.empty() && springs.empty()) return {};
  struct Applied {
    LoadSpec load;
    int v_index, q_index;
  };
  std::vector<Applied> applied;
  for (std::size_t k = 0; k < spec.loads.size(); ++k) {
    const LoadSpec& load = spec.loads[k];
    bool dynamic = false;
    for (const BodySpec& body : spec.bodies)
      dynamic = dynamic || (body.name == load.body && body.kind == BodySpec::Kind::Dynamic);
    if (!dynamic)
      throw InputError(spec.source + ": loads[" + std::to_string(k) + "].body: no dynamic body '" +
                       load.body + "' in the bodies list");
    const Body& b = model.bodies[model.bodyIndex(load.body)];
    // the acceleration each part gives the body (per second for a rate), against the bound
    // the inertia about the axis a torque turns least easily (2D: the z axis)
    const double inertia = spec.dimension == 2
                               ? b.inertia.inertia_com(2, 2)
                               : Eigen::SelfAdjointEigenSolver<Matrix3>(b.inertia.inertia_com)
                                     .eigenvalues()
                                     .minCoeff();
    const std::string where = spec.source + ": loads[" + std::to_string(k) + "].";
    for (const auto& [name, value, per] :
         {std::tuple<const char*, Vector3, double>{"force", load.force, b.inertia.mass},
          {"force_rate", load.force_rate, b.inertia.mass},
          {"torque", load.torque, inertia},
          {"torque_rate", load.torque_rate, inertia}})
      if (value.stableNorm() > kMaxAcceleration * per)
        throw InputError(where + name + ": " + formatValue(value.stableNorm()) + " gives body '" +
                         load.body + "' " + formatValue(value.stableNorm() / per) +
                         (name[0] == 'f' ? " m/s^2" : " rad/s^2") +
                         (std::string(name).find("rate") != std::string::npos ? " per s" : "") +
                         ", beyond " + formatValue(kMaxAcceleration));
    applied.push_back({load, b.v_index, b.q_index});
  }
  const bool planar = spec.dimension == 2;
  return [applied, springs, planar](double t, const VectorX& q, const VectorX&, VectorX& tau) {
    for (const Spring& s : springs) tau[s.v_index] -= s.stiffness * (q[s.q_index] - s.rest);
    for (const Applied& a : applied) {
      const Vector3 force = a.load.force + t * a.load.force_rate;
      const Vector3 torque = a.load.torque + t * a.load.torque_rate;
      if (planar) {
        tau[a.v_index] += force.x();
        tau[a.v_index + 1] += force.y();
        tau[a.v_index + 2] += torque.z();
      } else {
        Eigen::Quaterniond rotation;
        rotation.coeffs() = q.segment<4>(a.q_index + 3);
        tau.segment<3>(a.v_index) += force;
        tau.segment<3>(a.v_index + 3) += rotation.conjugate() * torque;
      }
    }
  };
}

}  // namespace

Scene buildScene(const SceneSpec& spec) {
  if (spec.dimension != 2 && spec.dimension != 3)
    throw InputError(spec.source + ": dimension must be 2 or 3, got " +
                     std::to_string(spec.dimension));
  std::map<std::string, double> density;
  for (const MaterialSpec& m : spec.materials) density[m.name] = m.density;
  auto densityOf = [&](const BodySpec& body) {
    if (body.material.empty()) return 0.0;
    const auto it = density.find(body.material);
    if (it == density.end())
      throw InputError(owner(body) + ": no material named '" + body.material + "'");
    return it->second;
  };

  if (!(spec.gravity.stableNorm() <= kMaxAcceleration))
    throw InputError(spec.source + ": gravity: |g| = " + formatValue(spec.gravity.stableNorm()) +
                     " m/s^2 is beyond " + formatValue(kMaxAcceleration));
  ModelBuilder mb(spec.source);
  mb.setGravity(spec.gravity);
  for (const BodySpec& body : spec.bodies) {
    if (isPlanarShape(body.shape.type) != (spec.dimension == 2))
      throw InputError(owner(body) + ": a " + shapeTypeName(body.shape.type) + " in a " +
                       std::to_string(spec.dimension) + "D scene");
    validateShape(body.shape, owner(body));
    if (body.kind == BodySpec::Kind::Dynamic) {
      if (isUnbounded(body.shape))
        throw InputError(owner(body) + ": a " + shapeTypeName(body.shape.type) +
                         " cannot move; make it fixed");
      const Inertia inertia = bodyInertia(body, densityOf(body), spec.dimension);
      if (spec.dimension == 2)
        addPlanarBody(mb, body.name, inertia);
      else
        addFreeBody(mb, body.name, inertia);
    } else if (body.kind == BodySpec::Kind::Driven) {
      const MotionSpec& m = body.motion;
      DrivenBody driven =
          m.kind == MotionSpec::Kind::Keyframes
              ? DrivenBody::keyframes(body.name, body.pose.rotation, m.times, m.positions)
              : DrivenBody::constantTwist(body.name, body.pose, m.linear_velocity,
                                          m.angular_velocity);
      driven.removal_time = m.removal_time;
      mb.addDrivenBody(driven);
    }
  }
  std::vector<std::pair<int, int>> urdf_bodies;  // [first, end) of each URDF's bodies
  for (const UrdfSpec& urdf : spec.urdfs) {
    UrdfOptions options;
    options.floating_base = urdf.floating_base;
    options.base_placement = urdf.base;
    options.name_prefix = urdf.prefix;
    options.package_paths = urdf.package_paths;
    options.missing_meshes = urdf.missing_meshes;
    options.collision_meshes = urdf.collision_meshes;
    const int first = mb.bodyCount();
    addUrdf(mb, urdf.file, options);
    urdf_bodies.emplace_back(first, mb.bodyCount());
  }
  for (const EquationSystem& system : spec.systems) mb.addSystem(system);
  for (const ConstraintFunction& constraint : spec.constraints) mb.addConstraint(constraint);

  Scene scene;
  scene.model = mb.build();
  const Model& model = scene.model;

  ContactModelBuilder cb(model);
  cb.setSettings(spec.detection);
  MaterialTable& table = cb.materials();
  table.setDefaultLaw(spec.default_law);
  for (const MaterialSpec& m : spec.materials) table.add(m.name);
  for (const ContactLawSpec& law : spec.laws)
    table.setLaw(table.id(law.material_a), table.id(law.material_b), law.law);
  auto materialId = [&](const std::string& name) { return name.empty() ? 0 : table.id(name); };

  scene.q0 = model.neutralConfiguration();
  scene.v0 = VectorX::Zero(model.nv);
  int driven = 0;
  // by name once: Model::bodyIndex searches the list, and 35 000 grains took a billion string
  // comparisons
  std::unordered_map<std::string, int> body_index;
  for (std::size_t i = 0; i < model.bodies.size(); ++i)
    body_index.emplace(model.bodies[i].name, static_cast<int>(i));
  for (const BodySpec& body : spec.bodies) {
    const int material = materialId(body.material);
    switch (body.kind) {
      case BodySpec::Kind::Fixed:
        cb.addGeometry(body.name, BodyRef::world(), body.pose, body.shape, material);
        break;
      case BodySpec::Kind::Driven:
        cb.addGeometry(body.name, BodyRef::driven(driven++), Pose::identity(), body.shape,
                       material);
        break;
      case BodySpec::Kind::Dynamic: {
        const auto found = body_index.find(body.name);
        const int index = found != body_index.end() ? found->second : model.bodyIndex(body.name);
        cb.addGeometry(body.name, BodyRef::dynamic(index), Pose::identity(), body.shape, material);
        const Body& b = model.bodies[index];
        if (spec.dimension == 2) {
          const Matrix3& R = body.pose.rotation;
          scene.q0.segment<3>(b.q_index) << body.pose.translation.x(), body.pose.translation.y(),
              std::atan2(R(1, 0), R(0, 0));
          scene.v0.segment<3>(b.v_index) << body.velocity.x(), body.velocity.y(),
              body.angular_velocity.z();
        } else {
          const Eigen::Quaterniond quaternion(body.pose.rotation);
          scene.q0.segment<3>(b.q_index) = body.pose.translation;
          scene.q0.segment<4>(b.q_index + 3) = quaternion.coeffs();
          scene.v0.segment<3>(b.v_index) = body.velocity;
          scene.v0.segment<3>(b.v_index + 3) =
              body.pose.rotation.transpose() * body.angular_velocity;
        }
        break;
      }
    }
  }

  std::vector<int> body_materials(model.bodies.size(), 0);
  std::vector<bool> joint_given(model.bodies.size(), false);
  for (std::size_t u = 0; u < spec.urdfs.size(); ++u) {
    const UrdfSpec& urdf = spec.urdfs[u];
    for (const auto& [joint, value] : urdf.joint_positions) {
      const int index = urdfJointBody(spec, model, u, "joints", joint);
      const Body& b = model.bodies[index];
      if (b.joint.nq() != 1)
        throw InputError(spec.source + ": urdf[" + std::to_string(u) + "].joints." + joint +
                         ": the joint has " + std::to_string(b.joint.nq()) +
                         " coordinates; set it by its state (--initial-state, set_state)");
      scene.q0[b.q_index] = value;
      joint_given[index] = true;
    }
    for (const auto& [joint, value] : urdf.joint_velocities) {
      const Body& b = model.bodies[urdfJointBody(spec, model, u, "velocities", joint)];
      if (b.joint.nv() != 1)
        throw InputError(spec.source + ": urdf[" + std::to_string(u) + "].velocities." + joint +
                         ": the joint has " + std::to_string(b.joint.nv()) +
                         " velocities; set it by its state (--initial-state, set_state)");
      scene.v0[b.v_index] = value;
    }
    const auto [first, end] = urdf_bodies[u];
    for (int b = first; b < end; ++b) body_materials[b] = materialId(urdf.material);
    for (const auto& [link, material] : urdf.link_materials) {
      int found = -1;
      for (int b = first; b < end; ++b)
        if (model.bodies[b].name == urdf.prefix + link) found = b;
      if (found < 0)
        throw InputError(spec.source + ": urdf[" + std::to_string(u) + "].link_materials." + link +
                         ": no such link in " + urdf.file);
      body_materials[found] = materialId(material);
    }
  }
  if (!spec.urdfs.empty()) cb.addModelCollisions(0, body_materials);
  for (std::size_t u = 0; u < spec.urdfs.size(); ++u)
    for (const UrdfSpec::Actuator& a : spec.urdfs[u].actuators) {
      const Body& b = model.bodies[urdfJointBody(spec, model, u, "actuators", a.drive.joint)];
      JointActuator drive = a.drive;
      drive.joint = b.joint_name;
      if (!a.max_torque_given) drive.max_torque = b.effort_limit;
      const std::string where =
          spec.source + ": urdf[" + std::to_string(u) + "].actuators." + a.drive.joint;
      addJointActuator(scene.model, drive, where);
      // a prescribed joint starts on its motion; one set elsewhere is an error
      if (!drive.prescribed) continue;
      const double start = drive.position.at(0.0);
      if (!joint_given[model.jointIndex(drive.joint)]) {
        scene.q0[b.q_index] = start;
        scene.v0[b.v_index] = drive.targetVelocity(0.0);
      } else if (std::abs(scene.q0[b.q_index] - start) > kMaxStartJointViolation) {
        throw InputError(where + ": the joint starts at " + formatValue(scene.q0[b.q_index]) +
                         " but its prescribed motion at " + formatValue(start) +
                         "; leave it out of joints: to start it there");
      }
    }
  scene.forces = sceneLoads(spec, model);
  scene.cmodel = cb.build();
  if (scene.model.nv == 0)
    throw InputError(spec.source + ": the scene has no dynamic body: nothing to simulate");
  // 1e6 m leaves a double 1e-10 m of precision: beyond it contacts, and q + h v, lose meaning
  for (const Body& body : scene.model.bodies)
    for (int k = 0; k < body.joint.nq(); ++k)
      if (std::abs(scene.q0[body.q_index + k]) > kMaxCoordinate)
        throw InputError(spec.source + ": body '" + body.name + "': coordinate " +
                         formatValue(scene.q0[body.q_index + k]) + " is beyond " +
                         formatValue(kMaxCoordinate) +
                         " (m or rad): no contact could be resolved at that distance");
  // velocities bounded as coordinates are: 1e300 m/s would end a step at 1e297 m, its energy
  // overflowing a double
  for (const Body& body : scene.model.bodies)
    for (int k = 0; k < body.joint.nv(); ++k)
      if (!(std::abs(scene.v0[body.v_index + k]) <= kMaxSpeed))
        throw InputError(spec.source + ": body '" + body.name + "': velocity " +
                         formatValue(scene.v0[body.v_index + k]) + " is beyond " +
                         formatValue(kMaxSpeed) + " (m/s or rad/s)");
  // a mimic joint not set follows its leader from the start; one set must agree with it
  resolveJointCouplings(scene.model, scene.q0, joint_given);
  rejectBrokenJoints(scene.model, scene.q0, kMaxStartJointViolation, spec.source, "at t = 0");
  if (spec.max_initial_overlap >= 0.0)
    rejectOverlaps(scene, 0.0, scene.q0, scene.v0, spec.max_initial_overlap, 0.0, spec.source,
                   "at t = 0");
  return scene;
}

}  // namespace sweep
