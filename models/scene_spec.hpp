#pragma once
// A scene as data: bodies with shapes, materials, contact laws, driven motions and URDF models,
// before any Model is built. Scene files (apps/sweep) parse into it, generators such as the
// Hall funnel produce it, and the exporter writes it back as an explicit scene file, so one
// scene has one description whichever way it was made.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "contact/contact_model.hpp"
#include "framework/urdf_import.hpp"
#include "models/granular.hpp"

namespace sweep {

struct MaterialSpec {
  std::string name;
  double density = 0.0;  // kg/m^3 (2D scenes: mass per unit thickness and area)
};

struct ContactLawSpec {
  std::string material_a, material_b;
  ContactLaw law;
};

// Prescribed motion of a driven body. The body frame starts at BodySpec::pose.
struct MotionSpec {
  enum class Kind { Fixed, Velocity, Keyframes };
  Kind kind = Kind::Fixed;
  Vector3 linear_velocity = Vector3::Zero();   // Velocity: of the body origin
  Vector3 angular_velocity = Vector3::Zero();  // Velocity: spin about the body origin
  std::vector<double> times;                   // Keyframes
  std::vector<Vector3> positions;              // Keyframes: of the body origin
  double removal_time = std::numeric_limits<double>::infinity();
};

struct BodySpec {
  enum class Kind { Dynamic, Fixed, Driven };
  std::string name;
  Kind kind = Kind::Dynamic;
  Shape shape;
  std::string material;                // empty: the default material
  Pose pose;                           // body frame in world at t = 0 (2D: rotation about z)
  Vector3 velocity = Vector3::Zero();  // Dynamic: of the body origin, world frame
  Vector3 angular_velocity = Vector3::Zero();  // Dynamic: world frame
  std::optional<double> mass;                  // default: density x volume (2D: area)
  std::optional<Vector3> principal_inertia;    // about the centroid, shape axes
  MotionSpec motion;                           // Driven
  // What the file wrote for the orientation and the mesh, so that `export` writes them back
  // and the exported scene builds to the same bits (a rotation matrix read back as angles
  // would differ in the last bit). Unset for bodies a generator made.
  std::optional<double> written_angle;    // 2D
  std::optional<Vector3> written_rpy;     // 3D
  std::optional<Vector3> written_normal;  // half-plane, plane
  std::string mesh_file;                  // mesh: the resolved path
  Vector3 mesh_scale = Vector3::Ones();
};

// An external load on a dynamic body of the bodies list, applied at the body's frame origin,
// world frame, linear in time (a ramp, or a constant with zero rates):
//   F(t) = force + force_rate t,   T(t) = torque + torque_rate t   (2D: z components only).
struct LoadSpec {
  std::string body;
  Vector3 force = Vector3::Zero(), force_rate = Vector3::Zero();
  Vector3 torque = Vector3::Zero(), torque_rate = Vector3::Zero();
};

struct UrdfSpec {
  std::string file;
  std::string prefix;
  bool floating_base = false;
  Pose base;
  std::optional<Vector3> written_rpy;      // as the file wrote it, for `export`
  std::vector<std::string> package_paths;  // resolved; UrdfOptions::package_paths
  MissingMeshes missing_meshes = MissingMeshes::Refuse;
  CollisionMeshes collision_meshes = CollisionMeshes::ConvexHull;
  std::vector<std::pair<std::string, double>> joint_positions, joint_velocities;
  std::string material;  // of every link's collisions, unless link_materials names the link
  std::vector<std::pair<std::string, std::string>> link_materials;  // (link, material)
  // linear springs on 1-dof joints: torque (or force) -stiffness (q - rest)
  struct JointSpring {
    std::string joint;
    double stiffness = 0.0, rest = 0.0;
  };
  std::vector<JointSpring> joint_springs;
  // motors and servos on its 1-dof joints (framework/actuator.hpp), joint names as the file
  // writes them; without max_torque given, the joint's <limit effort> bounds the torque
  struct Actuator {
    JointActuator drive;
    bool max_torque_given = false;
  };
  std::vector<Actuator> actuators;
};

struct SceneSpec {
  std::string source = "scene";  // names the scene in error messages
  int dimension = 2;
  Vector3 gravity = Vector3(0, -9.81, 0);
  std::vector<MaterialSpec> materials;
  ContactLaw default_law{0.0, 0.0};
  std::vector<ContactLawSpec> laws;
  std::vector<BodySpec> bodies;
  std::vector<UrdfSpec> urdfs;
  std::vector<LoadSpec> loads;
  // Systems by their equations and constraints by functions (code only: a scene file has no
  // syntax for callables); their coordinates follow the bodies', at their reference, at rest.
  std::vector<EquationSystem> systems;
  std::vector<ConstraintFunction> constraints;
  DetectionSettings detection;
  // Bodies that overlap by more than this at t = 0 (m) are an input error: a run would start
  // with an O(1) push-out or a silently wrong state. < 0: no check.
  double max_initial_overlap = 1e-9;
};

// Grain radii: one value, a normal law truncated at +-3 standard deviations (redrawn beyond),
// or a uniform law on [low, high].
struct RadiusDistribution {
  enum class Kind { Constant, Normal, Uniform };
  Kind kind = Kind::Constant;
  double a = 0.0;  // the radius, the mean, or the low end
  double b = 0.0;  // -, the standard deviation, or the high end

  static RadiusDistribution constant(double r) { return {Kind::Constant, r, 0.0}; }
  static RadiusDistribution normal(double mean, double std) { return {Kind::Normal, mean, std}; }
  static RadiusDistribution uniform(double low, double high) { return {Kind::Uniform, low, high}; }
};
std::vector<double> sampleRadii(const RadiusDistribution& distribution, int count,
                                std::uint32_t seed);

// Mass and inertia of a dynamic body about its frame: the shape's area (2D) or volume (3D)
// times the density, unless BodySpec overrides them. InputError when neither is possible
// (a mesh without explicit mass and inertia, a half-plane).
Inertia bodyInertia(const BodySpec& body, double density, int dimension);

// Builds the Model (dynamic bodies, then URDF trees, then systems; driven bodies), the ContactModel
// and the initial state. InputError naming the body for anything inconsistent.
Scene buildScene(const SceneSpec& spec);

// The largest coordinate a scene or a saved state may hold (m or rad).
inline constexpr double kMaxCoordinate = 1e6;
// How far a joint may start past a limit or off its mimic coupling (m or rad): a scene's
// start is exact, a saved state holds what its run's solves left.
inline constexpr double kMaxStartJointViolation = 1e-9;
inline constexpr double kMaxStateJointViolation = 1e-2;
// The largest velocity (m/s or rad/s): at it a body crosses the coordinate bound in a second.
inline constexpr double kMaxSpeed = 1e6;
// The longest step (s): a body at the speed bound crosses the coordinate bound in it.
inline constexpr double kMaxStep = kMaxCoordinate / kMaxSpeed;
// The largest acceleration gravity or a load may give a body (m/s^2 or rad/s^2, about 1e8 g),
// and a load's rate per second: beyond it a step of 1e-3 s alone exceeds the velocity bound.
inline constexpr double kMaxAcceleration = 1e9;

// Detection at (t, q, v) with a zero margin (driven bodies where they are at t): InputError
// "<where>: 'a' and 'b' overlap by X m <when>, more than ..." for the first pair deeper than
// max(max_overlap, max_relative_overlap x the smaller bounding radius of the two).
void rejectOverlaps(const Scene& scene, double t, const VectorX& q, const VectorX& v,
                    double max_overlap, double max_relative_overlap, const std::string& where,
                    const std::string& when);

}  // namespace sweep
