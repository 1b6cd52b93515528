#include "framework/urdf_import.hpp"

#include <console_bridge/console.h>
#include <tinyxml.h>
#include <urdf_parser/urdf_parser.h>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <cstdlib>
#include <limits>
#include <map>
#include <optional>
#include <vector>

#include "framework/error.hpp"
#include "framework/urdf_xml_checks.hpp"

namespace sweep {

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// urdfdom reports its reasons through console_bridge; keep them for our error message.
class CapturedLog : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_WARN) {
      if (!messages.empty()) messages += "; ";
      messages += text;
    }
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_ERROR) {
      if (!errors.empty()) errors += "; ";
      errors += text;
    }
  }
  std::string messages;
  // urdfdom logs some errors and goes on without the element it could not read (an
  // <inertial> with a bad origin): the model it returns is not the file's
  std::string errors;
};

// console_bridge restores by swapping its current and previous handlers, so after a capture
// it still holds a pointer to the capturing handler. That handler therefore lives for the
// whole program (one per thread), never on a stack frame that is gone.
//
// urdfdom passes some messages that quote the file (a bad xyz, a bad box size) to
// console_bridge as the printf format itself, so a '%s' or '%n' in a URDF crashes or writes
// memory. console_bridge formats only when the message's level is at or above its log level:
// with `format_messages` false the level is raised to NONE for the parse, nothing is
// formatted, and nothing is captured.
class LogCapture {
 public:
  explicit LogCapture(bool format_messages) : level_(console_bridge::getLogLevel()) {
    log().messages.clear();
    log().errors.clear();
    console_bridge::useOutputHandler(&log());
    if (!format_messages) console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_NONE);
  }
  ~LogCapture() {
    console_bridge::setLogLevel(level_);
    console_bridge::restorePreviousOutputHandler();
  }
  LogCapture(const LogCapture&) = delete;
  LogCapture& operator=(const LogCapture&) = delete;
  const std::string& messages() const { return log().messages; }
  const std::string& errors() const { return log().errors; }

 private:
  static CapturedLog& log() {
    thread_local CapturedLog instance;
    return instance;
  }
  console_bridge::LogLevel level_;
};

Pose toPose(const urdf::Pose& p) {
  Pose out;
  out.translation = Vector3(p.position.x, p.position.y, p.position.z);
  out.rotation = Quaternion(p.rotation.w, p.rotation.x, p.rotation.y, p.rotation.z)
                     .normalized()
                     .toRotationMatrix();
  return out;
}

std::string number(double x) {
  std::ostringstream s;
  s << x;
  return s.str();
}

class Importer {
 public:
  Importer(ModelBuilder& builder, const std::string& source, const std::string& base_dir,
           const UrdfOptions& options, std::map<std::string, LimitAttributes> limit_attributes)
      : builder_(builder),
        source_(source),
        base_dir_(base_dir),
        options_(options),
        limit_attributes_(std::move(limit_attributes)) {}

  int run(const urdf::ModelInterface& urdf) {
    const int first = addTrees(urdf);
    addMimicCouplings();
    return first;
  }

 private:
  int addTrees(const urdf::ModelInterface& urdf) {
    const urdf::LinkConstSharedPtr root = urdf.getRoot();
    if (!root) fail("<robot>", "has no root link");
    if (root->name == "world") {
      if (root->inertial && root->inertial->mass > 0.0)
        fail("link 'world'", "the world link cannot carry mass");
      int first = -1;
      for (const auto& joint : root->child_joints) {
        const int b = addJointAndSubtree(urdf, *joint, -1, options_.base_placement);
        if (first < 0) first = b;
      }
      if (first < 0) fail("link 'world'", "has no child joint: nothing to simulate");
      return first;
    }
    const Joint root_joint = options_.floating_base ? Joint::floating() : Joint::fixed();
    const int body = builder_.addBody(-1, options_.name_prefix + "root_joint", root_joint,
                                      options_.base_placement, linkInertia(*root),
                                      options_.name_prefix + root->name);
    addLinkContents(*root, body);
    addChildren(urdf, *root, body);
    return body;
  }

  // A <mimic> joint follows its leader, q = multiplier q_leader + offset: a bilateral
  // constraint in every solve, once the whole file is read (the leader may come later).
  void addMimicCouplings() {
    for (const Mimic& m : mimics_) {
      const std::string where = "joint '" + m.joint + "' <mimic>";
      const auto leader = joint_body_.find(m.leader);
      if (leader == joint_body_.end())
        fail(where, "it follows joint '" + m.leader + "', which is not in the file");
      if (m.leader == m.joint) fail(where, "a joint cannot follow itself");
      if (!std::isfinite(m.multiplier) || !std::isfinite(m.offset))
        fail(where, "multiplier and offset must be finite, got " + number(m.multiplier) + " and " +
                        number(m.offset));
      const auto one_dof = [&](const urdf::Joint& j) {
        if (j.type != urdf::Joint::REVOLUTE && j.type != urdf::Joint::CONTINUOUS &&
            j.type != urdf::Joint::PRISMATIC)
          fail(where, "mimic needs revolute, continuous or prismatic joints; joint '" + j.name +
                          "' is not");
      };
      one_dof(*joints_.at(m.joint));
      one_dof(*joints_.at(m.leader));
      builder_.addJointCoupling(joint_body_.at(m.joint), leader->second, m.multiplier, m.offset);
    }
  }

  // An <origin> beyond 1e6 m (the scene's coordinate bound) puts a body where no contact can
  // be resolved and ends the first step with a state that is not finite.
  Pose placement(const urdf::Pose& p, const std::string& where) const {
    const Vector3 xyz(p.position.x, p.position.y, p.position.z);
    if (!(xyz.cwiseAbs().maxCoeff() <= 1e6))
      fail(where, "xyz [" + number(xyz.x()) + " " + number(xyz.y()) + " " + number(xyz.z()) +
                      "] is beyond 1e+06 m");
    const Eigen::Vector4d q(p.rotation.w, p.rotation.x, p.rotation.y, p.rotation.z);
    if (!q.allFinite() || !(q.norm() > 0.0)) fail(where, "rpy is not finite");
    return toPose(p);
  }

  [[noreturn]] void fail(const std::string& element, const std::string& reason) const {
    throw InputError(source_ + ": " + element + ": " + reason);
  }

  Inertia linkInertia(const urdf::Link& link) const {
    if (!link.inertial) return Inertia::zero();  // links without <inertial> are massless
    const urdf::Inertial& in = *link.inertial;
    const std::string where = "link '" + link.name + "' <inertial>";
    if (!std::isfinite(in.mass)) fail(where, "mass is not finite");
    if (in.mass < 0.0) fail(where, "mass must be >= 0, got " + number(in.mass));
    Matrix3 inertia;
    inertia << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
    if (!inertia.allFinite()) fail(where, "inertia has non-finite entries");
    const Eigen::SelfAdjointEigenSolver<Matrix3> eig(inertia);
    const Vector3 principal = eig.eigenvalues();  // ascending
    const double scale = std::max(principal.cwiseAbs().maxCoeff(), 1e-300);
    if (in.mass > 0.0 && principal[0] <= 0.0)
      fail(where, "inertia tensor is not positive definite (principal moments " +
                      number(principal[0]) + ", " + number(principal[1]) + ", " +
                      number(principal[2]) + ")");
    if (principal[0] < -1e-12 * scale)
      fail(where, "inertia tensor has a negative principal moment " + number(principal[0]));
    // a real mass distribution has I1 + I2 >= I3 for its principal moments
    if (principal[0] + principal[1] < principal[2] * (1.0 - 1e-9))
      fail(where, "principal moments " + number(principal[0]) + ", " + number(principal[1]) + ", " +
                      number(principal[2]) + " violate the triangle inequality");
    const Pose frame = placement(in.origin, where + " <origin>");
    return Inertia{in.mass, frame.translation,
                   frame.rotation * inertia * frame.rotation.transpose()};
  }

  void addLinkContents(const urdf::Link& link, int body) {
    for (const auto& collision : link.collision_array) {
      if (!collision || !collision->geometry) continue;
      CollisionGeometry g;
      g.body = body;
      g.name = collision->name.empty() ? link.name : collision->name;
      const std::string where = "link '" + link.name + "' <collision>";
      g.placement = placement(collision->origin, where + " <origin>");
      readGeometry(*collision->geometry, where, g);
      if (g.type == GeometryType::Mesh) {
        g.mesh_hull = options_.collision_meshes == CollisionMeshes::ConvexHull;
        if (!g.missing_mesh.empty() && options_.missing_meshes != MissingMeshes::Refuse) {
          const bool boxed =
              options_.missing_meshes == MissingMeshes::InertiaBox && inertiaBox(link, g);
          builder_.addNote(
              source_ + ": link '" + link.name + "': mesh " + g.missing_mesh +
              (boxed ? "; its inertia box collides instead" : "; the link collides without it"));
          if (!boxed) continue;
        }
      }
      builder_.addCollision(g);
    }
    for (const auto& visual : link.visual_array) {
      if (!visual || !visual->geometry) continue;
      CollisionGeometry g;
      g.body = body;
      g.name = visual->name.empty() ? link.name : visual->name;
      const std::string where = "link '" + link.name + "' <visual>";
      // a visual never stops a run: one that is malformed or cannot be found is noted, and
      // the link is drawn by its collision shapes
      try {
        g.placement = placement(visual->origin, where + " <origin>");
        readGeometry(*visual->geometry, where, g);
      } catch (const InputError& e) {
        builder_.addNote(std::string(e.what()) + "; not drawn");
        continue;
      }
      if (!g.missing_mesh.empty()) {
        builder_.addNote(source_ + ": link '" + link.name + "': visual mesh " + g.missing_mesh +
                         "; drawn by its collision shapes");
        continue;
      }
      builder_.addVisual(g);
    }
  }

  void readGeometry(const urdf::Geometry& geometry, const std::string& where,
                    CollisionGeometry& g) {
    switch (geometry.type) {
      case urdf::Geometry::SPHERE:
        g.type = GeometryType::Sphere;
        g.radius = static_cast<const urdf::Sphere&>(geometry).radius;
        if (!(g.radius > 0)) fail(where, "sphere radius must be > 0, got " + number(g.radius));
        break;
      case urdf::Geometry::BOX: {
        const auto& d = static_cast<const urdf::Box&>(geometry).dim;
        g.type = GeometryType::Box;
        g.box_size = Vector3(d.x, d.y, d.z);
        if (!(g.box_size.minCoeff() > 0)) fail(where, "box sizes must be > 0");
        break;
      }
      case urdf::Geometry::CYLINDER: {
        const auto& c = static_cast<const urdf::Cylinder&>(geometry);
        g.type = GeometryType::Cylinder;
        g.radius = c.radius;
        g.length = c.length;
        if (!(g.radius > 0 && g.length > 0)) fail(where, "cylinder radius and length must be > 0");
        break;
      }
      case urdf::Geometry::MESH: {
        const auto& m = static_cast<const urdf::Mesh&>(geometry);
        g.type = GeometryType::Mesh;
        g.mesh_scale = Vector3(m.scale.x, m.scale.y, m.scale.z);
        if (!(g.mesh_scale.minCoeff() > 0.0) || !g.mesh_scale.allFinite())
          fail(where, "mesh scale must be > 0 and finite in each axis, got \"" + number(m.scale.x) +
                          " " + number(m.scale.y) + " " + number(m.scale.z) + "\"");
        g.mesh_file = resolveMesh(m.filename, g.missing_mesh);
        break;
      }
    }
  }

  // The file a mesh's name points to: file:// stripped, package://PKG/... in the package's
  // folder, a relative name from the URDF's folder. `missing` says why when there is no file.
  std::string resolveMesh(const std::string& name, std::string& missing) {
    namespace fs = std::filesystem;
    const std::string file_scheme = "file://", package_scheme = "package://";
    std::string path = name.rfind(file_scheme, 0) == 0 ? name.substr(file_scheme.size()) : name;
    if (path.rfind(package_scheme, 0) == 0) {
      const std::string rest = path.substr(package_scheme.size());
      const std::string package = rest.substr(0, rest.find('/'));
      const std::optional<fs::path> root = findPackage(package);
      if (!root) {
        missing = "'" + name + "': package '" + package + "' not found in " + packageSearch() +
                  "; add the folder that holds it to the scene's urdf[].package_paths";
        return path;
      }
      path = (*root / rest.substr(std::min(rest.size(), package.size() + 1))).string();
    } else if (!base_dir_.empty() && !fs::path(path).is_absolute()) {
      path = (fs::path(base_dir_) / path).string();
    }
    std::error_code error;
    if (!fs::is_regular_file(path, error))
      missing = path + ": mesh file not found" +
                (path != name ? " (the URDF names '" + name + "')" : std::string());
    return path;
  }

  // package_paths, then $ROS_PACKAGE_PATH: a folder named `package` holding package.xml, at
  // most four levels down, the shallowest (then the first by name) when several are; then the
  // URDF's folder and its ancestors: one named `package` (a description folder without ROS).
  std::optional<std::filesystem::path> findPackage(const std::string& package) {
    namespace fs = std::filesystem;
    if (package.empty()) return std::nullopt;
    const auto known = packages_.find(package);
    if (known != packages_.end()) return known->second;
    std::optional<fs::path> found;
    for (const std::string& root : packageRoots()) {
      std::error_code error;
      if (!fs::is_directory(root, error)) continue;
      std::pair<int, std::string> best{5, ""};
      const auto consider = [&](const fs::path& folder, int depth) {
        if (folder.filename() == package && fs::is_regular_file(folder / "package.xml", error))
          best = std::min(best, std::pair<int, std::string>{depth, folder.string()});
      };
      consider(fs::path(root), 0);
      std::size_t visited = 0;
      for (fs::recursive_directory_iterator
               it(root, fs::directory_options::skip_permission_denied, error),
           end;
           !error && it != end && ++visited < 100000; it.increment(error)) {
        if (it.depth() >= 3 || it->path().filename().string().rfind('.', 0) == 0)
          it.disable_recursion_pending();
        if (it->is_directory(error)) consider(it->path(), it.depth() + 1);
      }
      if (!best.second.empty()) {
        found = fs::path(best.second);
        break;
      }
    }
    if (!found && !base_dir_.empty())
      for (fs::path at = fs::absolute(base_dir_).lexically_normal(); !at.empty();
           at = at.parent_path()) {
        if (at.filename() == package) {
          found = at;
          break;
        }
        if (at == at.parent_path()) break;
      }
    packages_[package] = found;
    return found;
  }

  std::vector<std::string> packageRoots() const {
    std::vector<std::string> roots = options_.package_paths;
    if (const char* ros = std::getenv("ROS_PACKAGE_PATH")) {
      std::stringstream list(ros);
      for (std::string entry; std::getline(list, entry, ':');)
        if (!entry.empty()) roots.push_back(entry);
    }
    return roots;
  }

  std::string packageSearch() const {
    std::string where = "package_paths [";
    for (std::size_t k = 0; k < options_.package_paths.size(); ++k)
      where += (k ? ", " : "") + options_.package_paths[k];
    const char* ros = std::getenv("ROS_PACKAGE_PATH");
    return where + "], ROS_PACKAGE_PATH (" + (ros ? std::string(ros) : "unset") +
           ") or the URDF's folders";
  }

  // The box of the link's mass and inertia, at its inertial frame along its principal axes:
  // edges a^2 = 6 (I2 + I3 - I1) / m and so on. False for a massless link.
  bool inertiaBox(const urdf::Link& link, CollisionGeometry& g) const {
    if (!link.inertial || !(link.inertial->mass > 0.0)) return false;
    const urdf::Inertial& in = *link.inertial;
    Matrix3 inertia;
    inertia << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
    const Eigen::SelfAdjointEigenSolver<Matrix3> eig(inertia);
    const Vector3 I = eig.eigenvalues();
    Vector3 edges;
    for (int k = 0; k < 3; ++k)
      edges[k] = std::sqrt(std::max(0.0, 6.0 * (I[(k + 1) % 3] + I[(k + 2) % 3] - I[k]) / in.mass));
    if (!(edges.minCoeff() > 0.0)) edges = edges.cwiseMax(1e-3 * edges.maxCoeff());
    Matrix3 axes = eig.eigenvectors();
    if (axes.determinant() < 0.0) axes.col(2) = -axes.col(2);
    const Pose frame = toPose(in.origin);
    g.type = GeometryType::Box;
    g.box_size = edges;
    g.placement.translation = frame.translation;
    g.placement.rotation = frame.rotation * axes;
    return true;
  }

  Joint toJoint(const urdf::Joint& j) const {
    const std::string where = "joint '" + j.name + "'";
    const Vector3 axis(j.axis.x, j.axis.y, j.axis.z);
    const bool needs_axis = j.type == urdf::Joint::REVOLUTE || j.type == urdf::Joint::CONTINUOUS ||
                            j.type == urdf::Joint::PRISMATIC || j.type == urdf::Joint::PLANAR;
    if (needs_axis && !(axis.allFinite() && axis.norm() > 1e-12))
      fail(where, "axis must have non-zero length, got (" + number(axis.x()) + " " +
                      number(axis.y()) + " " + number(axis.z()) + ")");
    switch (j.type) {
      case urdf::Joint::REVOLUTE:
        return Joint::revolute(axis);
      case urdf::Joint::CONTINUOUS:
        return Joint::continuous(axis);
      case urdf::Joint::PRISMATIC:
        return Joint::prismatic(axis);
      case urdf::Joint::FIXED:
        return Joint::fixed();
      case urdf::Joint::FLOATING:
        return Joint::floating();
      case urdf::Joint::PLANAR:
        return Joint::planar(axis);
      default:
        fail(where, "unknown joint type");
    }
  }

  // Depth first and in file order, as a recursion would number the bodies, but with an explicit
  // stack: a chain of 10^5 links is a legal URDF and must not overflow the call stack.
  int addJointAndSubtree(const urdf::ModelInterface& urdf, const urdf::Joint& top, int top_parent,
                         const Pose& top_offset) {
    struct Pending {
      const urdf::Joint* joint;
      int parent;
      Pose offset;
    };
    std::vector<Pending> stack{{&top, top_parent, top_offset}};
    int first = -1;
    while (!stack.empty()) {
      const Pending next = stack.back();
      stack.pop_back();
      const int body = addJointBody(urdf, *next.joint, next.parent, next.offset);
      if (first < 0) first = body;
      const urdf::Link& link = *urdf.getLink(next.joint->child_link_name);
      pushChildren(link, body, stack);
    }
    return first;
  }

  template <class Stack>
  static void pushChildren(const urdf::Link& link, int body, Stack& stack) {
    for (auto j = link.child_joints.rbegin(); j != link.child_joints.rend(); ++j)
      stack.push_back({j->get(), body, Pose{}});
  }

  int addJointBody(const urdf::ModelInterface& urdf, const urdf::Joint& j, int parent,
                   const Pose& parent_offset) {
    const urdf::LinkConstSharedPtr link = urdf.getLink(j.child_link_name);
    if (!link) fail("joint '" + j.name + "'", "child link '" + j.child_link_name + "' not found");
    const int body = builder_.addBody(parent, options_.name_prefix + j.name, toJoint(j),
                                      parent_offset * placement(j.parent_to_joint_origin_transform,
                                                                "joint '" + j.name + "' <origin>"),
                                      linkInertia(*link), options_.name_prefix + link->name);
    joint_body_[j.name] = body;
    joints_[j.name] = &j;
    if (j.mimic)
      mimics_.push_back({j.name, j.mimic->joint_name, j.mimic->multiplier, j.mimic->offset});
    if ((j.type == urdf::Joint::REVOLUTE || j.type == urdf::Joint::PRISMATIC)) {
      if (!j.limits) fail("joint '" + j.name + "'", "revolute and prismatic joints need <limit>");
      if (!(std::isfinite(j.limits->lower) && std::isfinite(j.limits->upper)))
        fail("joint '" + j.name + "' <limit>", "lower and upper must be finite");
      // urdfdom reads an absent bound as 0; as Drake does, an absent bound is no bound, and a
      // joint whose two bounds are written equal is locked there
      const auto given = limit_attributes_.find(j.name);
      const double lower =
          given != limit_attributes_.end() && given->second.lower ? j.limits->lower : -kInfinity;
      const double upper =
          given != limit_attributes_.end() && given->second.upper ? j.limits->upper : kInfinity;
      if (lower > upper)
        fail("joint '" + j.name + "' <limit>",
             "lower " + number(lower) + " exceeds upper " + number(upper));
      if (lower > -kInfinity || upper < kInfinity) builder_.addJointLimits(body, lower, upper);
    }
    // an effort of 0 is read as none: urdfdom gives 0 where the attribute is absent
    if (j.limits && j.limits->effort > 0.0 && std::isfinite(j.limits->effort))
      builder_.setEffortLimit(body, j.limits->effort);
    addLinkContents(*link, body);
    return body;
  }

  void addChildren(const urdf::ModelInterface& urdf, const urdf::Link& link, int body) {
    for (const auto& joint : link.child_joints) addJointAndSubtree(urdf, *joint, body, Pose{});
  }

  ModelBuilder& builder_;
  std::string source_;
  std::string base_dir_;
  UrdfOptions options_;
  struct Mimic {
    std::string joint, leader;
    double multiplier, offset;
  };
  std::vector<Mimic> mimics_;
  std::map<std::string, LimitAttributes> limit_attributes_;
  std::map<std::string, int> joint_body_;
  std::map<std::string, std::optional<std::filesystem::path>>
      packages_;  // found, by name  // builder body of each joint's child link
  std::map<std::string, const urdf::Joint*> joints_;
};

int importParsed(ModelBuilder& builder, const std::string& xml, const std::string& source,
                 const std::string& base_dir, const UrdfOptions& options) {
  std::map<std::string, LimitAttributes> limit_attributes = precheckXml(xml, source);
  const std::size_t percent = xml.find('%');
  urdf::ModelInterfaceSharedPtr urdf;
  std::string reasons;
  {
    LogCapture capture(percent == std::string::npos);
    try {
      urdf = urdf::parseURDF(xml);
    } catch (const std::exception& e) {
      reasons = e.what();
    }
    if (reasons.empty()) reasons = capture.messages();
    if (urdf && !capture.errors().empty())
      throw InputError(source + ": urdfdom reported an error and left part of the file out: " +
                       capture.errors());
  }
  if (!urdf && reasons.empty() && percent != std::string::npos) {
    const auto line = 1 + std::count(xml.begin(), xml.begin() + percent, '\n');
    reasons = "urdfdom's reasons are withheld because the file holds a '%' (first on line " +
              std::to_string(line) +
              "), which urdfdom would hand to printf as a format; look for a '%' in a number";
  }
  if (!urdf)
    throw InputError(source + ": not a valid URDF" + (reasons.empty() ? "" : ": " + reasons));
  return Importer(builder, source, base_dir, options, std::move(limit_attributes)).run(*urdf);
}

}  // namespace

int addUrdfString(ModelBuilder& builder, const std::string& xml, const std::string& source,
                  const UrdfOptions& options) {
  return importParsed(builder, xml, source, "", options);
}

int addUrdf(ModelBuilder& builder, const std::string& path, const UrdfOptions& options) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw InputError(path + ": is a folder, not a URDF file");
  if (!std::filesystem::is_regular_file(path, ec))
    throw InputError(path + ": URDF file does not exist or is not a regular file");
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open URDF file");
  std::stringstream text;
  text << in.rdbuf();
  const std::string dir = std::filesystem::path(path).parent_path().string();
  return importParsed(builder, text.str(), path, dir, options);
}

Model loadUrdf(const std::string& path, const UrdfOptions& options) {
  ModelBuilder builder(path);
  addUrdf(builder, path, options);
  return builder.build();
}

}  // namespace sweep
