#include "contact/narrowphase_mesh.hpp"

#include <algorithm>
#include <cmath>

namespace sweep {

namespace {

constexpr double kConeTolerance = 1e-9;  // relative: a flat neighbour is inside the cone

// Whether d is in vertex v's normal cone: every neighbour lies behind the plane through v.
bool inVertexCone(const TriangleMesh& mesh, int v, const Vector3& d) {
  const Vector3& x = mesh.vertices[v];
  for (int j = mesh.around_start[v]; j < mesh.around_start[v + 1]; ++j)
    for (int u : mesh.triangles[mesh.around[j]]) {
      const Vector3 w = mesh.vertices[u] - x;
      if (d.dot(w) > kConeTolerance * w.norm()) return false;
    }
  return true;
}

// The third vertex of triangle t's direction from its edge (a, a + e), perpendicular to it:
// the way into the triangle.
Vector3 inward(const TriangleMesh& mesh, int t, const Vector3& a, const Vector3& e) {
  Vector3 w = Vector3::Zero();
  for (int v : mesh.triangles[t]) {
    const Vector3 u = mesh.vertices[v] - a;
    const Vector3 perpendicular = u - e * (e.dot(u) / e.squaredNorm());
    if (perpendicular.squaredNorm() > w.squaredNorm()) w = perpendicular;
  }
  return w;
}

// What the three kinds of points share, in the mesh's frame.
struct MeshContacts {
  const Pose& pose;
  const TriangleMesh& mesh;
  double margin;
  double depth;    // how far behind the mesh a point is still pushed back
  Vector3 center;  // the shape's bounding sphere, mesh frame
  double reach;    // its radius plus the margin
  std::vector<ContactPoint>& out;

  int corner_ids() const {
    return 4 * static_cast<int>(mesh.triangles.size()) + static_cast<int>(mesh.vertices.size());
  }
  // a point of the mesh, the normal from it to the shape (mesh frame) and the gap
  void emit(const Vector3& on_mesh, const Vector3& normal, double gap, int feature) const {
    if (!(gap < margin) || gap < -depth) return;
    ContactPoint c;
    c.gap = gap;
    c.normal = pose.rotation * normal;
    c.point_a = pose.apply(on_mesh);
    c.point_b = c.point_a + gap * c.normal;
    c.feature = feature;
    out.push_back(c);
  }
  bool near(const Vector3& x) const { return (x - center).norm() <= reach; }

  // Each convex vertex near the shape once (from the first triangle around it): f(v).
  template <class F>
  void forEachConvexVertex(F&& f) const {
    const Vector3 box = Vector3::Constant(reach);
    mesh.forEachTriangleIn(center - box, center + box, [&](int t) {
      for (int v : mesh.triangles[t])
        if (mesh.around[mesh.around_start[v]] == t && mesh.vertex_convex[v] &&
            near(mesh.vertices[v]))
          f(v);
    });
  }

  // Each convex edge near the shape once (from its lower triangle): f(t, k, a, e, normal
  // orientation m, the inward directions of its one or two triangles).
  template <class F>
  void forEachConvexEdge(F&& f) const {
    const Vector3 box = Vector3::Constant(reach);
    mesh.forEachTriangleIn(center - box, center + box, [&](int t) {
      for (int k = 0; k < 3; ++k) {
        const int other = mesh.across[t][k];
        if (mesh.edge_kind[t][k] <= 0 || (other >= 0 && other < t)) continue;
        const Vector3& a = mesh.vertices[mesh.triangles[t][k]];
        const Vector3 e = mesh.vertices[mesh.triangles[t][(k + 1) % 3]] - a;
        const double s = std::clamp((center - a).dot(e) / e.squaredNorm(), 0.0, 1.0);
        if (!near(a + s * e)) continue;
        Vector3 m = mesh.normals[t];
        const Vector3 w_t = inward(mesh, t, a, e);
        Vector3 w_o = w_t;
        if (other >= 0) {
          m += mesh.normals[other];
          w_o = inward(mesh, other, a, e);
        }
        f(t, k, a, e, m, w_t, w_o);
      }
    });
  }

  // The normal of a mesh edge (a, a + e) against a shape's edge (p, p + d), oriented out of
  // the mesh; false when parallel, when the closest points are not inside both, or when the
  // normal leaves the mesh edge's cone.
  bool edgeEdge(const Vector3& a, const Vector3& e, const Vector3& m, const Vector3& w_t,
                const Vector3& w_o, const Vector3& p, const Vector3& d, Vector3& on_mesh,
                Vector3& on_shape, Vector3& normal) const {
    double s = 0.0, t = 0.0;
    if (!detail::closestOnLines(a, e, p, d, s, t) || !(s > 0.0 && s < 1.0 && t > 0.0 && t < 1.0))
      return false;
    normal = e.cross(d).normalized();
    if (normal.dot(m) < 0.0) normal = -normal;
    if (normal.dot(w_t) > kConeTolerance * w_t.norm() ||
        normal.dot(w_o) > kConeTolerance * w_o.norm())
      return false;
    on_mesh = a + s * e;
    on_shape = p + t * d;
    return true;
  }
};

}  // namespace

void meshBox(const Pose& mesh_pose, const TriangleMesh& mesh, const Pose& box_pose,
             const Vector3& half_extents, double margin, std::vector<ContactPoint>& out) {
  const Pose box = mesh_pose.inverse() * box_pose;  // the box in the mesh's frame
  const double depth = half_extents.minCoeff();
  MeshContacts contacts{
      mesh_pose, mesh, margin, depth, box.translation, half_extents.norm() + margin, out};
  const int ids = contacts.corner_ids();

  // the corners against faces, ridges and rims
  auto corner = [&](int c) {
    return Vector3((c & 1) ? half_extents.x() : -half_extents.x(),
                   (c & 2) ? half_extents.y() : -half_extents.y(),
                   (c & 4) ? half_extents.z() : -half_extents.z());
  };
  for (int c = 0; c < 8; ++c)
    meshPoint(mesh_pose, mesh, box_pose.apply(corner(c)), 0.0, depth, margin, [&](ContactPoint p) {
      p.feature += c * ids;
      out.push_back(p);
    });

  // the mesh's convex vertices against the box's faces: a vertex outside one face only, or
  // inside the box (out through its nearest face)
  const int base_vertices = 8 * ids;
  const int vertices = static_cast<int>(mesh.vertices.size());
  contacts.forEachConvexVertex([&](int v) {
    const Vector3 x = box.rotation.transpose() * (mesh.vertices[v] - box.translation);
    const Vector3 excess = x.cwiseAbs() - half_extents;
    int face = 0, outside = 0;
    for (int i = 0; i < 3; ++i)
      if (excess[i] > 0.0) {
        ++outside;
        face = i;
      }
    if (outside > 1) return;  // nearest an edge or corner of the box: the other kinds
    if (outside == 0) excess.maxCoeff(&face);
    const Vector3 to_box = -(x[face] < 0.0 ? -1.0 : 1.0) * box.rotation.col(face);
    if (!inVertexCone(mesh, v, to_box)) return;
    contacts.emit(mesh.vertices[v], to_box, excess[face], base_vertices + v);
  });

  // the mesh's convex edges against the box's twelve edges: along axis i, at the signs
  // (+/-) of the other two
  const int base_edges = base_vertices + vertices;
  contacts.forEachConvexEdge([&](int t, int k, const Vector3& a, const Vector3& e, const Vector3& m,
                                 const Vector3& w_t, const Vector3& w_o) {
    for (int j = 0; j < 12; ++j) {
      const int i = j / 4, i1 = (i + 1) % 3, i2 = (i + 2) % 3;
      const double s1 = (j & 1) ? 1.0 : -1.0, s2 = (j & 2) ? 1.0 : -1.0;
      Vector3 start = Vector3::Zero();
      start[i] = -half_extents[i];
      start[i1] = s1 * half_extents[i1];
      start[i2] = s2 * half_extents[i2];
      const Vector3 p = box.apply(start);
      const Vector3 d = 2.0 * half_extents[i] * box.rotation.col(i);
      Vector3 on_mesh, on_box, normal;
      if (!contacts.edgeEdge(a, e, m, w_t, w_o, p, d, on_mesh, on_box, normal)) continue;
      // the box's outward normals at its edge face the mesh
      if (normal.dot(s1 * box.rotation.col(i1)) > kConeTolerance ||
          normal.dot(s2 * box.rotation.col(i2)) > kConeTolerance)
        continue;
      contacts.emit(on_mesh, normal, normal.dot(on_box - on_mesh),
                    base_edges + (3 * t + k) * 12 + j);
    }
  });
}

void meshCapsule(const Pose& mesh_pose, const TriangleMesh& mesh, const Vector3& start,
                 const Vector3& end, double radius, double margin, std::vector<ContactPoint>& out) {
  const Pose to_mesh = mesh_pose.inverse();
  const Vector3 p = to_mesh.apply(start), d = to_mesh.apply(end) - p;  // the axis, mesh frame
  MeshContacts contacts{
      mesh_pose, mesh, margin, radius, p + 0.5 * d, 0.5 * d.norm() + radius + margin, out};
  const int ids = contacts.corner_ids();

  // the rounded ends, as balls
  for (int c = 0; c < 2; ++c)
    meshBall(mesh_pose, mesh, c == 0 ? start : end, radius, margin, [&](ContactPoint point) {
      point.feature += c * ids;
      out.push_back(point);
    });
  if (!(d.squaredNorm() > 0.0)) return;

  // the mesh's convex vertices against the side, between the ends
  const int base_vertices = 2 * ids;
  const int vertices = static_cast<int>(mesh.vertices.size());
  contacts.forEachConvexVertex([&](int v) {
    const Vector3& x = mesh.vertices[v];
    const double s = (x - p).dot(d) / d.squaredNorm();
    if (!(s > 0.0 && s < 1.0)) return;  // an end's: the balls take it
    const Vector3 offset = p + s * d - x;
    const double distance = offset.norm();
    if (!(distance > 1e-12 * radius)) return;
    const Vector3 normal = offset / distance;
    if (!inVertexCone(mesh, v, normal)) return;
    contacts.emit(x, normal, distance - radius, base_vertices + v);
  });

  // the mesh's convex edges against the axis
  const int base_edges = base_vertices + vertices;
  contacts.forEachConvexEdge([&](int t, int k, const Vector3& a, const Vector3& e, const Vector3& m,
                                 const Vector3& w_t, const Vector3& w_o) {
    Vector3 on_mesh, on_axis, normal;
    if (!contacts.edgeEdge(a, e, m, w_t, w_o, p, d, on_mesh, on_axis, normal)) return;
    contacts.emit(on_mesh, normal, normal.dot(on_axis - on_mesh) - radius, base_edges + 3 * t + k);
  });

  // the axis clipped to each face's region: where it crosses a convex edge rising toward it
  // (it tilts down toward the face), the crossing against the face; the edge-axis point
  // takes the crossings where the axis falls away beyond the edge
  const int triangles = static_cast<int>(mesh.triangles.size());
  const int base_clips = base_edges + 3 * triangles;
  const Vector3 box = Vector3::Constant(contacts.reach);
  mesh.forEachTriangleIn(contacts.center - box, contacts.center + box, [&](int t) {
    const auto& tri = mesh.triangles[t];
    const Vector3& n = mesh.normals[t];
    double s_in = 0.0, s_out = 1.0;  // the axis's part over the face
    int edge_in = -1, edge_out = -1;
    for (int k = 0; k < 3; ++k) {
      const Vector3& v = mesh.vertices[tri[k]];
      const Vector3 inside = n.cross(mesh.vertices[tri[(k + 1) % 3]] - v);  // into the face
      const double at_start = inside.dot(p - v), rate = inside.dot(d);
      if (rate == 0.0) {
        if (at_start < 0.0) return;
        continue;
      }
      const double s = -at_start / rate;
      if (rate > 0.0 && s > s_in) {
        s_in = s;
        edge_in = k;
      } else if (rate < 0.0 && s < s_out) {
        s_out = s;
        edge_out = k;
      }
    }
    if (!(s_in < s_out)) return;
    const Vector3& origin = mesh.vertices[tri[0]];
    const double h_in = n.dot(p + s_in * d - origin), h_out = n.dot(p + s_out * d - origin);
    const double level = 1e-9 * radius;  // a level axis: the edge-axis points hold it
    auto crossing = [&](double s, int edge, double h, double other_h) {
      if (edge < 0 || mesh.edge_kind[t][edge] <= 0 || !(h > other_h + level)) return;
      const Vector3 x = p + s * d;
      contacts.emit(x - h * n, n, h - radius, base_clips + 3 * t + edge);
    };
    crossing(s_in, edge_in, h_in, h_out);
    crossing(s_out, edge_out, h_out, h_in);
  });
}

}  // namespace sweep
