#pragma once
// VTK snapshots for ParaView and `sweep view`: one PolyData file (.vtp) per snapshot, the
// bodies' shapes, and URDF links' visuals, as vertices (disks, spheres), lines (segments, the
// axes of capsules and cylinders, half-planes), polygons (2D polygons, the six faces of boxes,
// the triangles of meshes, a square of each plane under the other shapes), with body id, kind,
// shape type (ShapeType), role, radius, velocity and contact force as point data and the
// scene's dimension and gravity as field data; and a .pvd collection that lists the snapshots
// with their times, rewritten after each one so it is always valid.
// Beside each snapshot, the last step's contact network (vtk/contacts_NNNNNN.vtp, listed in
// contacts.pvd), as LMGC90 and LIGGGHTS write theirs: every contact that carried an impulse
// or overlaps, as three points with its values (its point, a vertex; the two bodies' centres, a
// line: the force chain's segment), with the normal, the normal and tangential impulses, the
// force, the gap and the two body ids as point data.
#include <string>
#include <vector>

#include "integrators/time_stepper.hpp"
#include "models/granular.hpp"

namespace sweep {

// A point's "role": a collision shape, a URDF link's visual (drawn, never in contact), or a
// collision shape of a link that its visuals draw (ParaView may show it; the viewer does not).
inline constexpr int kRoleCollision = 0, kRoleVisual = 1, kRoleHidden = 2;

// What one snapshot draws: the state at time t, and the last step (of length h)'s contacts
// with their impulses (normal, tangents), one per contact.
struct SnapshotView {
  double t = 0.0, h = 0.0;
  const VectorX& q;
  const VectorX& v;
  const std::vector<Contact>& contacts;
  const std::vector<Vector3>& impulses;
};

inline SnapshotView snapshotOf(const TimeStepper& stepper) {
  return SnapshotView{stepper.time(), stepper.settings().h,           stepper.q(),
                      stepper.v(),    stepper.contactData().contacts, stepper.impulses()};
}

class VtkSeries {
 public:
  VtkSeries(const Scene& scene, const std::string& out_dir);
  void write(const SnapshotView& view);
  void write(const TimeStepper& stepper) { write(snapshotOf(stepper)); }
  int count() const { return static_cast<int>(entries_.size()); }

 private:
  const Scene& scene_;
  std::string dir_;
  int dimension_ = 3;  // 2 when any shape is planar
  Data data_;
  ContactData cdata_;
  std::vector<std::pair<double, std::string>> entries_;  // time, file name
  std::vector<std::pair<double, std::string>> contact_entries_;
  struct VisualPart {
    int body;
    Pose placement;  // in the body frame
    Shape shape;
  };
  std::vector<VisualPart> visuals_;
  std::vector<char> drawn_by_visuals_;  // per body

  void writeContacts(const SnapshotView& view, const std::string& name);
};

}  // namespace sweep
