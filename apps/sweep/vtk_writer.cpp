#include "apps/sweep/vtk_writer.hpp"

#include <array>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <sstream>

#include "apps/sweep/run.hpp"
#include "contact/mesh_io.hpp"
#include "framework/error.hpp"
#include "framework/kinematics.hpp"

namespace sweep {

namespace {

struct Cell {
  enum class Kind { Vertex, Line, Polygon } kind;
  std::vector<int> points;
};

void writeCollection(const std::string& path,
                     const std::vector<std::pair<double, std::string>>& entries) {
  std::ostringstream pvd;
  pvd << std::setprecision(17)
      << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n<Collection>\n";
  for (const auto& [time, file] : entries)
    pvd << "<DataSet timestep=\"" << time << "\" part=\"0\" file=\"" << file << "\"/>\n";
  pvd << "</Collection>\n</VTKFile>\n";
  writeFileAtomically(path, pvd.str());
}

void vectorArray(std::ostringstream& x, const char* name, const std::vector<Vector3>& values) {
  x << "<DataArray type=\"Float64\" Name=\"" << name
    << "\" NumberOfComponents=\"3\" format=\"ascii\">\n";
  for (const Vector3& value : values)
    x << value.x() << ' ' << value.y() << ' ' << value.z() << '\n';
  x << "</DataArray>\n";
}

template <class T>
void scalarArray(std::ostringstream& x, const char* type, const char* name,
                 const std::vector<T>& values) {
  x << "<DataArray type=\"" << type << "\" Name=\"" << name << "\" format=\"ascii\">\n";
  for (const T& value : values) x << value << ' ';
  x << "\n</DataArray>\n";
}

}  // namespace

VtkSeries::VtkSeries(const Scene& scene, const std::string& out_dir)
    : scene_(scene), dir_(out_dir), data_(scene.model), cdata_(scene.model, scene.cmodel) {
  for (const Geometry& geometry : scene.cmodel.geometries)
    if (isPlanarShape(geometry.shape.type)) dimension_ = 2;
  std::filesystem::create_directories(dir_ + "/vtk");
  // a body with visuals is drawn by them; a visual mesh that cannot be read leaves its body
  // drawn by its collision shapes (the import has already noted a missing file)
  drawn_by_visuals_.assign(scene.model.bodies.size(), 0);
  for (const CollisionGeometry& visual : scene.model.visuals) {
    VisualPart part{visual.body, visual.placement, Shape{}};
    switch (visual.type) {
      case GeometryType::Sphere:
        part.shape = Shape::sphere(visual.radius);
        break;
      case GeometryType::Box:
        part.shape = Shape::box(visual.box_size);
        break;
      case GeometryType::Cylinder:
        part.shape = Shape::cylinder(visual.radius, visual.length);
        break;
      case GeometryType::Capsule:
        part.shape = Shape::capsule(visual.radius, visual.length);
        break;
      case GeometryType::Mesh:
        try {
          // drawn only: no topology, no checks of a surface that meets nothing
          part.shape.type = ShapeType::TriangleMesh;
          part.shape.mesh = loadTriangleMesh(visual.mesh_file, visual.mesh_scale);
        } catch (const InputError&) {
          continue;
        }
        break;
    }
    drawn_by_visuals_[visual.body] = 1;
    visuals_.push_back(std::move(part));
  }
}

void VtkSeries::write(const SnapshotView& view) {
  const Model& model = scene_.model;
  const ContactModel& cmodel = scene_.cmodel;
  const double t = view.t;
  forwardKinematics(model, data_, view.q, view.v);
  updateGeometryPoses(model, data_, cmodel, t, cdata_);

  // net contact force of the last step on every dynamic body, world frame
  std::vector<Vector3> force(model.bodies.size(), Vector3::Zero());
  const auto& contacts = view.contacts;
  const auto& impulses = view.impulses;
  const double h = view.h;
  for (std::size_t c = 0; c < contacts.size() && c < impulses.size(); ++c) {
    const Contact& k = contacts[c];
    const Vector3 f =
        (impulses[c].x() * k.normal + impulses[c].y() * k.tangent1 + impulses[c].z() * k.tangent2) /
        h;
    if (k.body_b.kind == BodyRef::Kind::Dynamic) force[k.body_b.index] += f;
    if (k.body_a.kind == BodyRef::Kind::Dynamic) force[k.body_a.index] -= f;
  }

  std::vector<Vector3> points;
  std::vector<int> body_id, kind, shape_type, role;
  std::vector<double> radius;
  std::vector<Vector3> velocity, contact_force;
  std::vector<Cell> cells;
  std::vector<int> unbounded;
  // one shape's points and cells; `part`: kRoleCollision, kRoleVisual or kRoleHidden
  auto emit = [&](const Shape& shape, const Pose& pose, BodyRef::Kind body_kind, int body,
                  int part) {
    Vector3 v = Vector3::Zero(), f = Vector3::Zero();
    if (body >= 0) {
      const Pose& bp = data_.world_pose[body];
      v = bp.rotation * Vector3(data_.velocity[body].tail<3>());
      f = force[body];
    }
    auto add = [&](const Vector3& x, double r) {
      points.push_back(x);
      body_id.push_back(body);
      kind.push_back(static_cast<int>(body_kind));
      shape_type.push_back(static_cast<int>(shape.type));
      role.push_back(part);
      radius.push_back(r);
      velocity.push_back(v);
      contact_force.push_back(f);
      return static_cast<int>(points.size()) - 1;
    };
    Cell cell;
    if (shape.type == ShapeType::Box) {
      // six quads on eight shared corners: a blade or a gate as it is, not as a ball
      int corner[8];
      for (int k = 0; k < 8; ++k)
        corner[k] = add(pose.apply(shape.half_extents.cwiseProduct(
                            Vector3(k & 1 ? 1.0 : -1.0, k & 2 ? 1.0 : -1.0, k & 4 ? 1.0 : -1.0))),
                        0.0);
      static const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                      {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
      for (const auto& face : faces) {
        Cell quad;
        quad.kind = Cell::Kind::Polygon;
        for (int k : face) quad.points.push_back(corner[k]);
        cells.push_back(quad);
      }
      return;
    }
    if (shape.type == ShapeType::Capsule || shape.type == ShapeType::Cylinder) {
      // the axis as a line with the radius: a roller drawn by ParaView's tube filter
      cell.kind = Cell::Kind::Line;
      cell.points = {add(pose.apply(Vector3(0.0, 0.0, -0.5 * shape.length)), shape.radius),
                     add(pose.apply(Vector3(0.0, 0.0, 0.5 * shape.length)), shape.radius)};
    } else if (shape.type == ShapeType::Segment) {
      cell.kind = Cell::Kind::Line;
      cell.points = {add(pose.apply(shape.segment_start), shape.radius),
                     add(pose.apply(shape.segment_end), shape.radius)};
    } else if ((shape.type == ShapeType::ConvexMesh || shape.type == ShapeType::TriangleMesh) &&
               shape.mesh) {
      // the triangles on the mesh's vertices: a hopper or a part as it is
      const int first = static_cast<int>(points.size());
      for (const Vector3& p : shape.mesh->vertices) add(pose.apply(p), 0.0);
      for (const auto& triangle : shape.mesh->triangles) {
        Cell face;
        face.kind = Cell::Kind::Polygon;
        for (int k : triangle) face.points.push_back(first + k);
        cells.push_back(face);
      }
      return;
    } else if (shape.type == ShapeType::Polygon) {
      cell.kind = Cell::Kind::Polygon;
      for (const Vector3& p : shape.vertices) cell.points.push_back(add(pose.apply(p), 0.0));
    } else {
      cell.kind = Cell::Kind::Vertex;
      cell.points = {add(pose.translation, boundingRadius(shape))};
    }
    cells.push_back(cell);
  };
  for (int g = 0; g < cmodel.size(); ++g) {
    const Geometry& geometry = cmodel.geometries[g];
    if (isUnbounded(geometry.shape)) {
      unbounded.push_back(g);
      continue;
    }
    if (geometry.body.kind == BodyRef::Kind::Driven &&
        !model.driven_bodies[geometry.body.index].presentAt(t))
      continue;
    const bool dynamic = geometry.body.kind == BodyRef::Kind::Dynamic;
    const int body = dynamic ? geometry.body.index : -1;
    emit(geometry.shape, cdata_.geometry_pose[g], geometry.body.kind, body,
         dynamic && drawn_by_visuals_[body] ? kRoleHidden : kRoleCollision);
  }
  for (const VisualPart& part : visuals_)
    emit(part.shape, data_.world_pose[part.body] * part.placement, BodyRef::Kind::Dynamic,
         part.body, kRoleVisual);

  // planes as a square and half-planes as a segment, centred under the other shapes and 1.2
  // times their extent wide (1 m with nothing else to measure): ParaView and the viewer draw
  // the floor a scene stands on
  Vector3 low = Vector3::Constant(std::numeric_limits<double>::infinity()), high = -low;
  for (std::size_t k = 0; k < points.size(); ++k) {
    low = low.cwiseMin(points[k] - Vector3::Constant(radius[k]));
    high = high.cwiseMax(points[k] + Vector3::Constant(radius[k]));
  }
  const bool measured = !points.empty() && (high - low).allFinite();
  const Vector3 middle = measured ? Vector3(0.5 * (low + high)) : Vector3::Zero();
  const double half = measured ? std::max(0.6 * (high - low).maxCoeff(), 1e-6) : 0.5;
  for (int g : unbounded) {
    const Geometry& geometry = cmodel.geometries[g];
    const Pose& pose = cdata_.geometry_pose[g];
    const bool planar = geometry.shape.type == ShapeType::HalfPlane;
    const Vector3 normal = pose.rotation.col(planar ? 1 : 2);
    const Vector3 foot = middle - (middle - pose.translation).dot(normal) * normal;
    auto corner = [&](double along, double across) {
      points.push_back(
          foot + half * (along * pose.rotation.col(0) +
                         across * (planar ? Vector3::Zero() : Vector3(pose.rotation.col(1)))));
      body_id.push_back(-1);
      kind.push_back(static_cast<int>(geometry.body.kind));
      shape_type.push_back(static_cast<int>(geometry.shape.type));
      role.push_back(kRoleCollision);
      radius.push_back(0.0);
      velocity.push_back(Vector3::Zero());
      contact_force.push_back(Vector3::Zero());
      return static_cast<int>(points.size()) - 1;
    };
    Cell cell;
    if (planar) {
      cell.kind = Cell::Kind::Line;
      cell.points = {corner(-1.0, 0.0), corner(1.0, 0.0)};
    } else {
      cell.kind = Cell::Kind::Polygon;
      cell.points = {corner(-1.0, -1.0), corner(1.0, -1.0), corner(1.0, 1.0), corner(-1.0, 1.0)};
    }
    cells.push_back(cell);
  }

  std::ostringstream x;
  x << std::setprecision(9);
  int verts = 0, lines = 0, polys = 0;
  for (const Cell& c : cells)
    (c.kind == Cell::Kind::Vertex ? verts : c.kind == Cell::Kind::Line ? lines : polys) += 1;
  x << "<?xml version=\"1.0\"?>\n"
    << "<VTKFile type=\"PolyData\" version=\"0.1\" byte_order=\"LittleEndian\">\n"
    << "<PolyData>\n"
    << "<FieldData>\n<DataArray type=\"Int32\" Name=\"dimension\" NumberOfTuples=\"1\" "
       "format=\"ascii\">"
    << dimension_ << "</DataArray>\n"
    << "<DataArray type=\"Float64\" Name=\"gravity\" NumberOfComponents=\"3\" "
       "NumberOfTuples=\"1\" format=\"ascii\">"
    << model.gravity.x() << ' ' << model.gravity.y() << ' ' << model.gravity.z()
    << "</DataArray>\n</FieldData>\n"
    << "<Piece NumberOfPoints=\"" << points.size() << "\" NumberOfVerts=\"" << verts
    << "\" NumberOfLines=\"" << lines << "\" NumberOfStrips=\"0\" NumberOfPolys=\"" << polys
    << "\">\n";
  x << "<PointData Scalars=\"radius\" Vectors=\"velocity\">\n";
  scalarArray(x, "Int32", "body_id", body_id);
  scalarArray(x, "Int32", "kind", kind);
  scalarArray(x, "Int32", "shape", shape_type);
  scalarArray(x, "Int32", "role", role);
  scalarArray(x, "Float64", "radius", radius);
  vectorArray(x, "velocity", velocity);
  vectorArray(x, "contact_force", contact_force);
  x << "</PointData>\n<Points>\n";
  vectorArray(x, "points", points);
  x << "</Points>\n";
  auto cellBlock = [&](const char* tag, Cell::Kind k) {
    x << "<" << tag << ">\n<DataArray type=\"Int32\" Name=\"connectivity\" format=\"ascii\">\n";
    for (const Cell& c : cells)
      if (c.kind == k)
        for (int p : c.points) x << p << ' ';
    x << "\n</DataArray>\n<DataArray type=\"Int32\" Name=\"offsets\" format=\"ascii\">\n";
    int offset = 0;
    for (const Cell& c : cells)
      if (c.kind == k) x << (offset += static_cast<int>(c.points.size())) << ' ';
    x << "\n</DataArray>\n</" << tag << ">\n";
  };
  cellBlock("Verts", Cell::Kind::Vertex);
  cellBlock("Lines", Cell::Kind::Line);
  cellBlock("Polys", Cell::Kind::Polygon);
  x << "</Piece>\n</PolyData>\n</VTKFile>\n";

  std::ostringstream number;
  number << std::setw(6) << std::setfill('0') << entries_.size() << ".vtp";
  const std::string name = "vtk/snapshot_" + number.str();
  writeFileAtomically(dir_ + "/" + name, x.str());
  writeContacts(view, "vtk/contacts_" + number.str());
  entries_.emplace_back(t, name);
  writeCollection(dir_ + "/snapshots.pvd", entries_);
}

void VtkSeries::writeContacts(const SnapshotView& view, const std::string& name) {
  const auto& contacts = view.contacts;
  const auto& impulses = view.impulses;
  const double h = view.h;
  std::vector<Vector3> points, normal, tangential_impulse, force;
  std::vector<double> normal_impulse, gap;
  std::vector<int> body_a, body_b;
  int written = 0;
  for (std::size_t c = 0; c < contacts.size() && c < impulses.size(); ++c) {
    const Contact& k = contacts[c];
    const Vector3& P = impulses[c];
    if (P.isZero(0.0) && k.gap > 0.0) continue;
    // a body's centre, or the contact's point on a side that is not a dynamic body; b's
    // centre moved with the periodic image the pair meets (point_b is on that image)
    const Vector3 image = k.point_a + k.gap * k.normal - k.point_b;
    auto centre = [&](const BodyRef& body, const Vector3& point, const Vector3& shift) {
      return body.kind == BodyRef::Kind::Dynamic
                 ? Vector3(data_.world_pose[body.index].translation + shift)
                 : point;
    };
    const Vector3 tangential = P.y() * k.tangent1 + P.z() * k.tangent2;
    const std::array<Vector3, 3> at = {k.point_a + 0.5 * k.gap * k.normal,
                                       centre(k.body_a, k.point_a, Vector3::Zero()),
                                       centre(k.body_b, k.point_b + image, image)};
    for (const Vector3& point : at) {
      points.push_back(point);
      normal.push_back(k.normal);
      normal_impulse.push_back(P.x());
      tangential_impulse.push_back(tangential);
      force.push_back((P.x() * k.normal + tangential) / h);
      gap.push_back(k.gap);
      body_a.push_back(k.body_a.kind == BodyRef::Kind::Dynamic ? k.body_a.index : -1);
      body_b.push_back(k.body_b.kind == BodyRef::Kind::Dynamic ? k.body_b.index : -1);
    }
    ++written;
  }
  std::ostringstream x;
  x << std::setprecision(9) << "<?xml version=\"1.0\"?>\n"
    << "<VTKFile type=\"PolyData\" version=\"0.1\" byte_order=\"LittleEndian\">\n<PolyData>\n"
    << "<Piece NumberOfPoints=\"" << points.size() << "\" NumberOfVerts=\"" << written
    << "\" NumberOfLines=\"" << written
    << "\" NumberOfStrips=\"0\" NumberOfPolys=\"0\">\n<PointData Scalars=\"normal_impulse\" "
       "Vectors=\"force\">\n";
  scalarArray(x, "Float64", "normal_impulse", normal_impulse);
  vectorArray(x, "tangential_impulse", tangential_impulse);
  vectorArray(x, "normal", normal);
  vectorArray(x, "force", force);
  scalarArray(x, "Float64", "gap", gap);
  scalarArray(x, "Int32", "body_a", body_a);
  scalarArray(x, "Int32", "body_b", body_b);
  x << "</PointData>\n<Points>\n";
  vectorArray(x, "points", points);
  x << "</Points>\n";
  auto cells = [&](const char* tag, int first, int size) {
    x << "<" << tag << ">\n<DataArray type=\"Int32\" Name=\"connectivity\" format=\"ascii\">\n";
    for (int c = 0; c < written; ++c)
      for (int k = 0; k < size; ++k) x << 3 * c + first + k << ' ';
    x << "\n</DataArray>\n<DataArray type=\"Int32\" Name=\"offsets\" format=\"ascii\">\n";
    for (int c = 1; c <= written; ++c) x << size * c << ' ';
    x << "\n</DataArray>\n</" << tag << ">\n";
  };
  cells("Verts", 0, 1);
  cells("Lines", 1, 2);
  x << "</Piece>\n</PolyData>\n</VTKFile>\n";
  writeFileAtomically(dir_ + "/" + name, x.str());
  contact_entries_.emplace_back(view.t, name);
  writeCollection(dir_ + "/contacts.pvd", contact_entries_);
}

}  // namespace sweep
