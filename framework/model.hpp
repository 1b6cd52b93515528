#pragma once
// The immutable description of a multibody system: a forest of bodies, each attached to its
// parent (or the world) by one joint, plus kinematically driven bodies, joint limits and
// collision geometry records. Built once by ModelBuilder; algorithms take it by const
// reference together with a Data workspace (framework/data.hpp).
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "framework/actuator.hpp"
#include "framework/joint.hpp"
#include "framework/spatial.hpp"

namespace sweep {

using VectorX = Eigen::VectorXd;
using MatrixX = Eigen::MatrixXd;

struct Body {
  // first what the kinematics and the contact rows read for every contact, in the struct's
  // first cache lines (a powder bed reads them for thousands of bodies per step)
  int parent = -1;  // -1: the world
  int q_index = 0;
  int v_index = 0;
  int component = 0;
  Joint joint;
  Pose joint_placement;  // joint frame in the parent body frame (or world)
  Inertia inertia;       // in the body frame
  std::string name;
  std::string joint_name;
  // the URDF's <limit effort> (N m, or N on a prismatic joint); infinity where none is given.
  // An actuator's torque limit unless it sets its own.
  double effort_limit = std::numeric_limits<double>::infinity();
};

// Bodies connected to the world through one root joint. M is block diagonal over components;
// a component's bodies, coordinates and velocities are contiguous.
struct Component {
  int first_body = 0;
  int end_body = 0;  // one past the last
  int q_index = 0;
  int nq = 0;
  int v_index = 0;
  int nv = 0;
  // a single body whose mass block does not depend on q: computed and inverted once
  bool constant_mass = false;
  int system = -1;  // >= 0: Model::systems[system], a component without bodies
};

// A system given by its equations rather than by bodies and joints (docs/python.md, "Systems
// by their equations"): nq coordinates and nv velocities of its own, a component of the model
// beside the body trees, with
//   M(q) dv/dt = f(t, q, v) + (constraint impulses),   q (+) dv by `integrate`.
struct EquationSystem {
  std::string name;
  int nq = 0, nv = 0;
  std::function<MatrixX(const VectorX& q)> mass;  // nv x nv, symmetric positive definite
  bool constant_mass = false;                     // M(q) does not depend on q: built once
  // generalized forces on its velocities (gravity, springs, drives); null: none
  std::function<VectorX(double t, const VectorX& q, const VectorX& v)> forces;
  // q (+) dv where the coordinates are not a vector space; null: q + dv (then nq == nv)
  std::function<VectorX(const VectorX& q, const VectorX& dv)> integrate;
  std::function<double(const VectorX& q)> potential;  // its potential energy, for diagnostics
  VectorX reference;  // the neutral configuration (empty: zeros), where M must be invertible
};

// A unilateral constraint given by functions of the whole model's q (nq entries): the gap
// g(q) >= 0, its normal W_N(q) with dg/dt = W_N^T v (nv entries), and for friction one tangent
// direction W_T(q) (two in a 3D problem), with the Coulomb coefficient and Newton's restitution.
// It enters the same index sets and solves as geometric contacts and joint limits.
struct ConstraintFunction {
  std::string name;
  std::function<double(const VectorX& q)> gap;
  std::function<VectorX(const VectorX& q)> normal;
  std::function<VectorX(const VectorX&q)> tangent, tangent2;  // null: none
  double friction = 0.0, restitution = 0.0;
  // g(q) = 0 rather than >= 0 (a closed loop): its impulse takes either sign, it is in every
  // solve, and it has no friction or restitution
  bool bilateral = false;
  // a rheonomic bilateral constraint g(q, t) = gap(q) - drive(t) = 0 (a prescribed joint
  // motion), held at each step's end (integrators/contact_assembly.cpp; null: none)
  std::function<double(double t)> drive;
};

// A one-sided bound on a 1-dof joint, kept as a unilateral constraint for the contact solve:
// gap = side * (q[q_index] - bound) >= 0 with side = +1 for a lower and -1 for an upper limit.
struct JointLimit {
  int body = 0;
  int q_index = 0;
  int v_index = 0;
  double bound = 0.0;
  double side = 1.0;
};

enum class GeometryType { Sphere, Box, Cylinder, Capsule, Mesh };

// Collision geometry attached to a body, as read from URDF or a scene; contact/ turns these
// into shapes.
struct CollisionGeometry {
  int body = 0;
  std::string name;
  Pose placement;  // geometry frame in the body frame
  GeometryType type = GeometryType::Sphere;
  double radius = 0.0;                 // sphere, cylinder, capsule
  double length = 0.0;                 // cylinder, capsule (along the local z axis)
  Vector3 box_size = Vector3::Zero();  // full edge lengths
  std::string mesh_file;
  Vector3 mesh_scale = Vector3::Ones();
  bool mesh_hull = false;  // the mesh's convex hull rather than its triangles
  // why the mesh file the URDF names was not found (empty: it was); the geometry is then a
  // box standing for it, or still a mesh that the contact layer refuses with this reason
  std::string missing_mesh;
};

// A body without degrees of freedom whose pose and velocity are prescribed functions of time
// (a blade, a roller, a shutter). Its velocity enters contact velocities as a known term.
struct DrivenBody {
  std::string name;
  std::function<Pose(double)> pose;  // body frame in world at time t
  // world-frame twist (angular velocity, velocity of the body origin) at time t
  std::function<Vector6(double)> twist;
  // from this time on the body is gone (a shutter pulled away): it meets nothing
  double removal_time = std::numeric_limits<double>::infinity();

  bool presentAt(double t) const { return t < removal_time; }
  // world velocity at time t of the body's material point now at world position `point`
  Vector3 pointVelocity(const Vector3& point, double t) const {
    const Vector6 v = twist(t);
    return v.tail<3>() + v.head<3>().cross(point - pose(t).translation);
  }

  static DrivenBody fixed(const std::string& name, const Pose& pose);
  static DrivenBody constantTwist(const std::string& name, const Pose& pose0,
                                  const Vector3& linear_velocity, const Vector3& angular_velocity);
  // Origin moving piecewise linearly through `positions` at strictly increasing `times`,
  // orientation fixed; it rests at the first and last keyframe outside their span.
  static DrivenBody keyframes(const std::string& name, const Matrix3& rotation,
                              const std::vector<double>& times,
                              const std::vector<Vector3>& positions);
};

// q[follower] = multiplier * q[leader] + offset between two 1-dof joints (a URDF <mimic>),
// by body index. Each joint follows at most one leader and no chain of couplings closes.
struct JointCoupling {
  int follower = 0, leader = 0;
  double multiplier = 1.0, offset = 0.0;
};

struct Model {
  std::vector<Body> bodies;
  std::vector<Component> components;
  std::vector<JointLimit> limits;
  std::vector<CollisionGeometry> collisions;
  // a URDF's <visual> elements: drawn by the VTK snapshots and the viewer, never in contact
  std::vector<CollisionGeometry> visuals;
  std::vector<DrivenBody> driven_bodies;
  std::vector<EquationSystem> systems;  // their components follow the body trees'
  std::vector<ConstraintFunction> constraints;
  std::vector<JointCoupling> couplings;  // also in `constraints`, as bilateral functions
  std::vector<JointActuator> actuators;  // addJointActuator (framework/actuator.hpp)
  // what an import changed from its file (a missing mesh left out or replaced), for the run's
  // description
  std::vector<std::string> notes;
  Vector3 gravity = Vector3(0, 0, -9.81);
  int nq = 0;
  int nv = 0;

  int bodyIndex(const std::string& name) const;   // throws InputError if absent
  int jointIndex(const std::string& name) const;  // index of the body the joint moves
  const Component& componentOf(int body) const { return components[bodies[body].component]; }
  // the neutral configuration: zero coordinates, identity quaternions
  VectorX neutralConfiguration() const;
  // A name per entry of v: the joint's, with :x :y :theta for a planar joint and
  // :vx :vy :vz :wx :wy :wz for a floating one (docs/conventions.md)
  std::vector<std::string> dofNames() const;
  int dofIndex(const std::string& name) const;  // InputError naming it if absent
};

class ModelBuilder {
 public:
  explicit ModelBuilder(std::string source = "model") : source_(std::move(source)) {}

  // Adds a body attached to `parent` (-1 for the world); returns its index in this builder.
  int addBody(int parent, const std::string& joint_name, const Joint& joint,
              const Pose& joint_placement, const Inertia& inertia, const std::string& body_name);
  // An infinite bound is no bound; lower == upper locks the joint at that value.
  void addJointLimits(int body, double lower, double upper);
  void addCollision(const CollisionGeometry& geometry);
  void addVisual(const CollisionGeometry& geometry);
  void addDrivenBody(const DrivenBody& body);
  void setGravity(const Vector3& gravity);
  // A system by its equations (its coordinates and velocities come after every body's), and a
  // constraint by functions; InputError naming the missing or inconsistent part.
  void addSystem(const EquationSystem& system);
  void addConstraint(const ConstraintFunction& constraint);
  // q[follower] = multiplier * q[leader] + offset between two 1-dof joints (a URDF <mimic>):
  // a bilateral constraint by functions, after those added by addConstraint.
  void addJointCoupling(int follower, int leader, double multiplier, double offset);
  void addNote(const std::string& note) { notes_.push_back(note); }
  void setEffortLimit(int body, double effort) { bodies_.at(body).effort_limit = effort; }
  int bodyCount() const { return static_cast<int>(bodies_.size()); }

  // Orders bodies component by component (depth-first), assigns coordinate indices and checks
  // that every degree of freedom moves some inertia (M positive definite).
  Model build() const;

 private:
  std::string source_;
  std::vector<Body> bodies_;
  std::vector<JointLimit> limits_;  // body indices of this builder
  std::vector<CollisionGeometry> collisions_, visuals_;
  std::vector<DrivenBody> driven_;
  std::vector<EquationSystem> systems_;
  std::vector<ConstraintFunction> constraints_;
  std::vector<JointCoupling> couplings_;  // body indices of this builder
  std::vector<std::string> notes_;
  Vector3 gravity_ = Vector3(0, 0, -9.81);
};

// Sets q of every coupled joint whose body is not marked in `given` from its leader, leaders
// first, so that the couplings hold exactly (`given` empty: none is given).
void resolveJointCouplings(const Model& model, VectorX& q, const std::vector<bool>& given = {});

// InputError "<where>: joint 'j' is at X <when>, past its upper limit U by D" for the first
// joint limit or mimic coupling violated by more than max_violation (m or rad). Constraints by
// functions are left alone: they hold their velocity, from wherever they start.
void rejectBrokenJoints(const Model& model, const VectorX& q, double max_violation,
                        const std::string& where, const std::string& when);

}  // namespace sweep
