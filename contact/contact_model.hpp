#pragma once
// What never changes during a run on the contact side: the shapes attached to bodies, the
// materials and their contact laws, and the detection path chosen for the scene.
#include <array>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "contact/material.hpp"
#include "contact/shape.hpp"
#include "framework/model.hpp"

#include "framework/enum_names.hpp"

namespace sweep {

// The frame a shape is attached to: the world, a body of the Model (any joint), or a
// kinematically driven body (Model::driven_bodies).
struct BodyRef {
  enum class Kind { World, Dynamic, Driven };
  Kind kind = Kind::World;
  int index = -1;

  static BodyRef world() { return {}; }
  static BodyRef dynamic(int body) { return {Kind::Dynamic, body}; }
  static BodyRef driven(int body) { return {Kind::Driven, body}; }
  bool hasDofs() const { return kind == Kind::Dynamic; }
  bool operator==(const BodyRef& o) const { return kind == o.kind && index == o.index; }
};

struct Geometry {
  std::string name;
  BodyRef body;
  Pose placement;  // shape frame in the body frame
  Shape shape;
  int material = 0;
};

// Analytic: closed-form narrowphase for the pairs a scene holds (disk-disk, disk-segment,
// disk-half-plane, polygon-half-plane; sphere-sphere, sphere-half-space, sphere-box,
// convex-half-space) and a uniform-grid broadphase. Fcl: FCL's dynamic AABB tree and its
// narrowphase (GJK/EPA through libccd for general convex pairs, BVH for meshes).
enum class DetectionPath { Analytic, Fcl };
enum class DetectionPathChoice { Automatic, Analytic, Fcl };
template <>
struct EnumNames<DetectionPathChoice> {
  static constexpr EnumName<DetectionPathChoice> table[] = {
      {DetectionPathChoice::Automatic, "automatic"},
      {DetectionPathChoice::Analytic, "analytic"},
      {DetectionPathChoice::Fcl, "fcl"}};
};

const char* detectionPathName(DetectionPath path);

// Periodic boundaries along one world axis: space repeats with period high - low, so a grain
// near `high` touches the grains near `low` through their image shifted by one period, and
// free bodies leaving [low, high) re-enter at the other side (wrapPeriodic, after each step).
// Images are built for balls (spheres, disks) on free bodies; other shapes must not cross the
// boundaries (a blade or a plate spans the period instead).
struct Periodicity {
  int axis = -1;  // 0, 1, 2 (x, y, z); -1: off
  double low = 0.0, high = 0.0;
  bool enabled() const { return axis >= 0; }
  double period() const { return high - low; }
};

// Which speeds set the margin of a pair of two balls (spheres, disks); every other pair keeps
// the absolute rule. docs/contact.md, "The margin, relative".
enum class MarginRule {
  Absolute,  // the largest speed of any shape point in the world frame
  // The balls' centres only, about the middle of their velocities' bounding box: a ball turning
  // about its centre moves no surface, and grains carried along together close no gap between
  // them. Needs verify_margin, which checks the end velocities against it.
  Relative,
};
template <>
struct EnumNames<MarginRule> {
  static constexpr EnumName<MarginRule> table[] = {{MarginRule::Absolute, "absolute"},
                                                   {MarginRule::Relative, "relative"}};
};

struct DetectionSettings {
  DetectionPathChoice path = DetectionPathChoice::Automatic;
  // Candidate contacts are pairs with gap below the margin
  //   margin = speed_factor * h * (largest speed of a shape point) + floor,
  // so that every contact that can close during the step is in the solve.
  double speed_factor = 2.0;
  MarginRule margin_rule = MarginRule::Absolute;
  // After the solve, check the margin against the end velocities: a pair left out had a gap
  // of at least the margin at q_m, and closes by q_{k+1} only if h * (fastest end speed)
  // exceeds it. A step that fails is detected and solved again with twice the end speed's
  // margin, so that a speed_factor below 2 is safe to use. Under the gap-aware laws (IQS,
  // POS) only: VEL solves the closed contacts, which the margin does not decide.
  bool verify_margin = true;
  // < 0: automatic, 1e-3 times the smallest size (radius or half extent) of a moving shape
  double floor = -1.0;
  // pairs of bodies in the same articulated component (self-collision of a robot)
  bool self_collision = false;
  Periodicity periodic;

  void validate() const;  // InputError on negative or non-finite values
};

struct ContactModel {
  std::vector<Geometry> geometries;
  MaterialTable materials;
  DetectionSettings settings;
  int dimension = 3;  // 2 when every shape is planar: one tangent per contact
  DetectionPath path = DetectionPath::Fcl;
  std::string path_reason;  // one line for the run log: why this path was chosen
  double margin_floor = 0.0;
  // the smallest size (radius or half extent) of a moving bounded shape, 0 without one: the
  // scale penetrations are read against
  double smallest_size = 0.0;
  bool frictionless = true;  // every law that can apply has mu = 0 and mu_r = 0
  bool rolling = false;      // some law that can apply has mu_r > 0: rolling rows are built
  // the largest adhesion_range of the adhesive laws that can apply; < 0 when none is adhesive
  double adhesion_reach = -1.0;
  bool adhesive() const { return adhesion_reach >= 0.0; }
  // periodic scenes: the q index of each free body's coordinate along the periodic axis and
  // that coordinate's world offset (the body's joint placement); wrapped by wrapPeriodic
  std::vector<std::pair<int, double>> periodic_coordinates;

  // per geometry, what the per-pair work reads, packed (40 bytes) so that a step over 10^5
  // grains does not stream whole Geometry records through the cache
  struct Traits {
    BodyRef body_ref;
    int body = -1;       // dynamic body index, or -1 - driven index, or a large negative: world
    int component = -1;  // component of a dynamic body, -1 otherwise
    int material = 0;
    ShapeType type = ShapeType::Sphere;
    bool moving = false;
    bool unbounded = false;
    bool identity_placement = false;
    double ball_radius = -1.0;  // sphere and disk radius, -1 for other shapes
  };
  std::vector<Traits> traits;

  int size() const { return static_cast<int>(geometries.size()); }
  // whether geometries a and b are tested at all: not on one body, at least one with dofs,
  // not two half-spaces, not two bodies of one articulated component (unless self_collision)
  bool mayCollide(int a, int b) const {
    const Traits& fa = traits[a];
    const Traits& fb = traits[b];
    if (fa.body == fb.body || !(fa.moving || fb.moving) || (fa.unbounded && fb.unbounded))
      return false;
    return settings.self_collision || fa.component < 0 || fa.component != fb.component;
  }
};

// Moves every free body whose coordinate along the periodic axis left [low, high) back by one
// period. No-op without periodic boundaries. Returns the number of bodies moved.
int wrapPeriodic(const ContactModel& cmodel, VectorX& q);

// One line for the run log: shape count, dimension, detection path and why, margin floor,
// and whether the friction stage is needed.
std::string describe(const ContactModel& cmodel);

class ContactModelBuilder {
 public:
  explicit ContactModelBuilder(const Model& model) : model_(model) {}

  MaterialTable& materials() { return materials_; }
  void setSettings(const DetectionSettings& settings) { settings_ = settings; }

  int addGeometry(const std::string& name, BodyRef body, const Pose& placement, const Shape& shape,
                  int material = 0);
  // Turns Model::collisions (URDF collision elements) into geometries; meshes are read from
  // their files (triangle meshes). body_materials[b], where given and >= 0, overrides
  // `material` for the collisions of body b (a robot's rubber feet on a steel frame).
  void addModelCollisions(int material = 0, const std::vector<int>& body_materials = {});

  // Validates every shape (InputError naming body and shape) and picks the detection path.
  ContactModel build() const;

 private:
  // on a body with dofs somewhere between it and the world
  bool moves(const Geometry& g) const;
  std::string ownerName(const Geometry& g) const;
  void addPeriodicCoordinates(ContactModel& cm) const;

  const Model& model_;
  MaterialTable materials_;
  DetectionSettings settings_;
  std::vector<Geometry> geometries_;
  // boxes of one size share their surface mesh (a granular scene of boxes has few sizes)
  std::map<std::array<double, 3>, std::shared_ptr<const TriangleMesh>> box_surfaces_;
};

}  // namespace sweep
