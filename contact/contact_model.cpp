#include "contact/contact_model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "contact/convex_hull.hpp"
#include "contact/mesh_io.hpp"
#include "contact/narrowphase_analytic.hpp"
#include "framework/error.hpp"

namespace sweep {

const char* detectionPathName(DetectionPath path) {
  return path == DetectionPath::Analytic ? "analytic narrowphase + uniform grid"
                                         : "FCL (dynamic AABB tree, GJK/EPA)";
}

void DetectionSettings::validate() const {
  const auto show = formatValue;
  if (!(std::isfinite(speed_factor) && speed_factor >= 0.0))
    throw InputError("detection.speed_factor must be >= 0, got " + show(speed_factor));
  // a resting heap gets the floor as its margin: only the check of the end velocities makes
  // a grain set moving within the step safe
  if (margin_rule == MarginRule::Relative && !verify_margin)
    throw InputError("detection.margin_rule: relative needs detection.verify_margin: true");
  if (!std::isfinite(floor)) throw InputError("detection.floor must be finite, got " + show(floor));
  if (periodic.enabled()) {
    if (periodic.axis > 2)
      throw InputError("detection.periodic.axis must be x, y or z, got " +
                       std::to_string(periodic.axis));
    if (!(std::isfinite(periodic.low) && std::isfinite(periodic.high) &&
          periodic.high > periodic.low))
      throw InputError("detection.periodic: high must be > low, both finite, got [" +
                       show(periodic.low) + ", " + show(periodic.high) + "]");
  }
}

int wrapPeriodic(const ContactModel& cmodel, VectorX& q) {
  const Periodicity& p = cmodel.settings.periodic;
  if (!p.enabled()) return 0;
  int moved = 0;
  const double period = p.period();
  for (const auto& [index, offset] : cmodel.periodic_coordinates) {
    const double x = q[index] + offset;
    if (x >= p.low && x < p.high) continue;
    q[index] -= period * std::floor((x - p.low) / period);
    ++moved;
  }
  return moved;
}

std::string describe(const ContactModel& cmodel) {
  std::ostringstream out;
  out << "contact: " << cmodel.size() << " shapes (" << cmodel.dimension << "D), detection "
      << detectionPathName(cmodel.path) << " (" << cmodel.path_reason << "), margin floor "
      << cmodel.margin_floor << " m, "
      << (cmodel.settings.margin_rule == MarginRule::Relative ? "relative ball margins, " : "")
      << "friction " << (cmodel.frictionless ? "off (every mu = 0)" : "on")
      << (cmodel.rolling ? ", rolling resistance on" : "")
      << (cmodel.adhesive() ? ", adhesion on" : "");
  if (cmodel.settings.periodic.enabled())
    out << ", periodic along "
        << "xyz"[cmodel.settings.periodic.axis] << " on [" << cmodel.settings.periodic.low << ", "
        << cmodel.settings.periodic.high << ")";
  return out.str();
}

bool ContactModelBuilder::moves(const Geometry& g) const {
  if (!g.body.hasDofs()) return false;
  // a link welded to the world by fixed joints (a URDF's base under a "world" link) is as
  // still as the world: its pairs with the world's shapes would be rows without velocities
  for (int b = g.body.index; b >= 0; b = model_.bodies[b].parent)
    if (model_.bodies[b].joint.type != JointType::Fixed) return true;
  return false;
}

std::string ContactModelBuilder::ownerName(const Geometry& g) const {
  std::string body;
  switch (g.body.kind) {
    case BodyRef::Kind::World:
      body = "world";
      break;
    case BodyRef::Kind::Dynamic:
      body = "body '" + model_.bodies[g.body.index].name + "'";
      break;
    case BodyRef::Kind::Driven:
      body = "driven body '" + model_.driven_bodies[g.body.index].name + "'";
      break;
  }
  return body + ", shape '" + g.name + "'";
}

int ContactModelBuilder::addGeometry(const std::string& name, BodyRef body, const Pose& placement,
                                     const Shape& shape, int material) {
  const int count = body.kind == BodyRef::Kind::Dynamic
                        ? static_cast<int>(model_.bodies.size())
                        : static_cast<int>(model_.driven_bodies.size());
  if (body.kind != BodyRef::Kind::World && (body.index < 0 || body.index >= count))
    throw InputError("shape '" + name + "': body index " + std::to_string(body.index) +
                     " out of range");
  if (material < 0 || material >= materials_.size())
    throw InputError("shape '" + name + "': unknown material " + std::to_string(material));
  if (!placement.translation.allFinite() || !placement.rotation.allFinite())
    throw InputError("shape '" + name + "': placement is not finite");
  geometries_.push_back(Geometry{name, body, placement, shape, material});
  Shape& added = geometries_.back().shape;
  if (added.type == ShapeType::Box && !added.mesh && added.half_extents.allFinite() &&
      (added.half_extents.array() > 0.0).all()) {  // an invalid size: validateShape names it
    const Vector3& h = added.half_extents;
    std::shared_ptr<const TriangleMesh>& surface = box_surfaces_[{h.x(), h.y(), h.z()}];
    if (!surface) surface = closedBoxMesh(h);
    added.mesh = surface;
  }
  return static_cast<int>(geometries_.size()) - 1;
}

void ContactModelBuilder::addModelCollisions(int material, const std::vector<int>& body_materials) {
  for (std::size_t k = 0; k < model_.collisions.size(); ++k) {
    const CollisionGeometry& c = model_.collisions[k];
    const std::size_t body = static_cast<std::size_t>(c.body);
    const int chosen =
        body < body_materials.size() && body_materials[body] >= 0 ? body_materials[body] : material;
    const std::string name =
        c.name.empty() ? model_.bodies[c.body].name + "/collision" + std::to_string(k) : c.name;
    Shape shape;
    switch (c.type) {
      case GeometryType::Sphere:
        shape = Shape::sphere(c.radius);
        break;
      case GeometryType::Box:
        shape = Shape::box(c.box_size);
        break;
      case GeometryType::Cylinder:
        shape = Shape::cylinder(c.radius, c.length);
        break;
      case GeometryType::Capsule:
        shape = Shape::capsule(c.radius, c.length);
        break;
      case GeometryType::Mesh:
        if (!c.missing_mesh.empty())
          throw InputError(
              "body '" + model_.bodies[c.body].name + "', shape '" + name +
              "' (mesh): " + c.missing_mesh +
              " (urdf[].missing_meshes: skip or inertia_box loads the robot without it)");
        try {
          const auto mesh = loadTriangleMesh(c.mesh_file, c.mesh_scale);
          // the hull as a closed triangle surface: the closed forms against balls, boxes and
          // capsules take it, where a convex mesh would send those pairs to FCL's single point
          shape = Shape::triangleMesh(c.mesh_hull ? convexHull(*mesh, c.mesh_file) : mesh);
        } catch (const InputError& e) {
          throw InputError("body '" + model_.bodies[c.body].name + "', shape '" + name +
                           "' (mesh): " + e.what());
        }
        break;
    }
    addGeometry(name, BodyRef::dynamic(c.body), c.placement, shape, chosen);
  }
}

namespace {
// the size that sets the scale of gaps for a shape: radius, or least half extent
double characteristicSize(const Shape& s) {
  switch (s.type) {
    case ShapeType::Sphere:
    case ShapeType::Disk:
    case ShapeType::Capsule:
    case ShapeType::Cylinder:
      return s.radius;
    case ShapeType::Box:
      return s.half_extents.minCoeff();
    default:
      return boundingRadius(s);
  }
}
// what the laws that can apply (pairs of the used materials) ask of the solve: friction,
// rolling rows, adhesion's reach; a 2D scene with a surface energy is refused
void setLawFlags(const MaterialTable& materials, const std::set<int>& used, ContactModel& cm) {
  cm.frictionless = true;
  for (int a : used)
    for (int b : used) {
      const ContactLaw& law = materials.law(a, b);
      if (law.friction > 0.0 || law.rolling > 0.0) cm.frictionless = false;
      cm.rolling = cm.rolling || law.rolling > 0.0;
      if (!law.adhesive()) continue;
      // 4 pi gamma R* is a force; a 2D scene's forces are per unit thickness
      if (cm.dimension == 2 && law.surface_energy > 0.0)
        throw InputError("contact law '" + materials.name(a) + "'-'" + materials.name(b) +
                         "': surface_energy " + formatValue(law.surface_energy) +
                         " is a 3D law (pull-off force 4 pi gamma R*); a 2D scene gives "
                         "adhesion_force, per unit thickness");
      cm.adhesion_reach = std::max(cm.adhesion_reach, law.adhesion_range);
    }
}
}  // namespace

// Periodic scenes: images exist for balls on free bodies only, through the analytic path, and
// the period must hold a grain and its neighbours; anything else is refused here rather than
// silently missing contacts across the boundary.
void ContactModelBuilder::addPeriodicCoordinates(ContactModel& cm) const {
  const Periodicity& p = settings_.periodic;
  if (cm.path != DetectionPath::Analytic)
    throw InputError("detection.periodic needs the analytic detection path (" + cm.path_reason +
                     ")");
  if (cm.dimension == 2 && p.axis == 2)
    throw InputError("detection.periodic.axis: a 2D scene repeats along x or y, got z");
  double largest = 0.0;
  for (const Geometry& g : geometries_) {
    if (!moves(g)) continue;
    const Body& body = model_.bodies[g.body.index];
    const bool ball = g.shape.type == ShapeType::Sphere || g.shape.type == ShapeType::Disk;
    const bool free_body = body.parent < 0 && (body.joint.type == JointType::Floating ||
                                               (body.joint.type == JointType::Planar &&
                                                body.joint.plane_x == Vector3::UnitX() &&
                                                body.joint.plane_y == Vector3::UnitY()));
    if (!ball || !free_body || !g.placement.translation.isZero(0.0) ||
        body.joint_placement.rotation != Matrix3::Identity())
      throw InputError(ownerName(g) +
                       ": periodic boundaries take free spheres or disks (centred on their "
                       "body) as moving shapes, got a " +
                       shapeTypeName(g.shape.type) + " on joint '" + body.joint_name + "'");
    largest = std::max(largest, g.shape.radius);
    cm.periodic_coordinates.emplace_back(body.q_index + p.axis,
                                         body.joint_placement.translation[p.axis]);
  }
  if (!(p.period() > 6.0 * largest))
    throw InputError("detection.periodic: the period " + formatValue(p.period()) +
                     " must exceed three largest grain diameters (" + formatValue(6.0 * largest) +
                     ")");
}

ContactModel ContactModelBuilder::build() const {
  settings_.validate();
  ContactModel cm;
  cm.geometries = geometries_;
  cm.materials = materials_;
  cm.settings = settings_;

  int planar = 0;
  for (const Geometry& g : geometries_) {
    validateShape(g.shape, ownerName(g));
    planar += isPlanarShape(g.shape.type) ? 1 : 0;
  }
  if (planar != 0 && planar != cm.size()) {
    for (const Geometry& g : geometries_)
      if (!isPlanarShape(g.shape.type))
        throw InputError(ownerName(g) +
                         ": a 3D shape in a scene of 2D shapes (disk, segment, "
                         "polygon, half-plane); use one kind only");
  }
  cm.dimension = planar > 0 ? 2 : 3;

  // the analytic path serves the scene when every pair of shape types that can meet has a
  // closed form; decided by types and the components that own them, once. Without
  // self-collision two shapes of one component never meet: a robot's mesh links among
  // themselves do not send the scene to FCL.
  struct Owners {
    int count = 0, first = 0;
    bool several = false;  // more than one component (-1: the world or a driven body)
    void add(int component) {
      if (count++ == 0)
        first = component;
      else if (component != first)
        several = true;
    }
  };
  std::map<ShapeType, Owners> moving, all;
  for (const Geometry& g : geometries_) {
    const int component =
        g.body.kind == BodyRef::Kind::Dynamic ? model_.bodies[g.body.index].component : -1;
    all[g.shape.type].add(component);
    if (moves(g)) moving[g.shape.type].add(component);
  }
  std::string missing;
  for (const auto& [m, of_m] : moving)
    for (const auto& [a, of_a] : all) {
      const bool meet = settings_.self_collision
                            ? a != m || of_a.count > 1
                            : of_m.several || of_a.several || of_m.first != of_a.first;
      if (missing.empty() && meet && !hasAnalyticNarrowphase(m, a))
        missing = std::string(shapeTypeName(m)) + "-" + shapeTypeName(a);
    }
  const bool analytic_possible = missing.empty();
  switch (settings_.path) {
    case DetectionPathChoice::Automatic:
      cm.path = analytic_possible ? DetectionPath::Analytic : DetectionPath::Fcl;
      cm.path_reason = analytic_possible ? "every pair that can meet has a closed form"
                                         : "the " + missing + " pair has no closed form in Sweep";
      break;
    case DetectionPathChoice::Analytic:
      if (!analytic_possible)
        throw InputError("detection.path = analytic, but the " + missing +
                         " pair has no closed form; use automatic or fcl");
      cm.path = DetectionPath::Analytic;
      cm.path_reason = "requested";
      break;
    case DetectionPathChoice::Fcl:
      cm.path = DetectionPath::Fcl;
      cm.path_reason = "requested";
      break;
  }

  double smallest = std::numeric_limits<double>::infinity();
  for (const Geometry& g : geometries_)
    if (moves(g) && !isUnbounded(g.shape))
      smallest = std::min(smallest, characteristicSize(g.shape));
  cm.smallest_size = std::isfinite(smallest) ? smallest : 0.0;
  cm.margin_floor = settings_.floor >= 0.0 ? settings_.floor : 1e-3 * cm.smallest_size;

  for (const Geometry& g : geometries_) {
    ContactModel::Traits f;
    f.body_ref = g.body;
    f.material = g.material;
    f.type = g.shape.type;
    f.moving = moves(g);
    f.unbounded = isUnbounded(g.shape);
    f.identity_placement =
        g.placement.translation.isZero(0.0) && g.placement.rotation == Matrix3::Identity();
    if (g.shape.type == ShapeType::Sphere || g.shape.type == ShapeType::Disk)
      f.ball_radius = g.shape.radius;
    switch (g.body.kind) {
      case BodyRef::Kind::Dynamic:
        f.body = g.body.index;
        f.component = model_.bodies[g.body.index].component;
        break;
      case BodyRef::Kind::Driven:
        f.body = -1 - g.body.index;
        break;
      case BodyRef::Kind::World:
        f.body = std::numeric_limits<int>::min();
        break;
    }
    cm.traits.push_back(f);
  }

  std::set<int> used;
  for (const Geometry& g : geometries_) used.insert(g.material);
  setLawFlags(materials_, used, cm);
  if (settings_.periodic.enabled()) addPeriodicCoordinates(cm);
  return cm;
}

}  // namespace sweep
