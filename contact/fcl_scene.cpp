#include "contact/fcl_scene.hpp"

#include <fcl/fcl.h>

#include <algorithm>
#include <limits>

namespace sweep {

namespace {

using FclGeometry = std::shared_ptr<fcl::CollisionGeometryd>;

// A polygon becomes a prism through the scene plane, tall enough that no closest point of a
// pair lies on its top or bottom face.
std::shared_ptr<fcl::Convexd> prism(const std::vector<Vector3>& polygon, double half_height) {
  const int n = static_cast<int>(polygon.size());
  auto vertices = std::make_shared<std::vector<fcl::Vector3d>>();
  for (const Vector3& p : polygon) vertices->emplace_back(p.x(), p.y(), -half_height);
  for (const Vector3& p : polygon) vertices->emplace_back(p.x(), p.y(), half_height);
  auto faces = std::make_shared<std::vector<int>>();
  faces->push_back(n);  // bottom, seen from below
  for (int i = n - 1; i >= 0; --i) faces->push_back(i);
  faces->push_back(n);  // top
  for (int i = 0; i < n; ++i) faces->push_back(n + i);
  for (int i = 0; i < n; ++i) {
    const int j = (i + 1) % n;
    faces->insert(faces->end(), {4, i, j, n + j, n + i});
  }
  return std::make_shared<fcl::Convexd>(vertices, n + 2, faces);
}

std::shared_ptr<fcl::Convexd> convexMesh(const TriangleMesh& mesh) {
  auto vertices =
      std::make_shared<std::vector<fcl::Vector3d>>(mesh.vertices.begin(), mesh.vertices.end());
  auto faces = std::make_shared<std::vector<int>>();
  for (const auto& t : mesh.triangles) faces->insert(faces->end(), {3, t[0], t[1], t[2]});
  return std::make_shared<fcl::Convexd>(vertices, static_cast<int>(mesh.triangles.size()), faces);
}

std::shared_ptr<fcl::BVHModel<fcl::OBBRSSd>> triangleMesh(const TriangleMesh& mesh) {
  auto model = std::make_shared<fcl::BVHModel<fcl::OBBRSSd>>();
  model->beginModel(static_cast<int>(mesh.triangles.size()),
                    static_cast<int>(mesh.vertices.size()));
  std::vector<fcl::Triangle> triangles;
  for (const auto& t : mesh.triangles) triangles.emplace_back(t[0], t[1], t[2]);
  std::vector<fcl::Vector3d> vertices(mesh.vertices.begin(), mesh.vertices.end());
  model->addSubModel(vertices, triangles);
  model->endModel();
  return model;
}

}  // namespace

struct FclScene::Impl {
  std::vector<FclGeometry> geometry;  // null for half-spaces
  std::vector<Pose> offset;           // FCL shape frame in the Sweep shape frame
  std::vector<std::unique_ptr<fcl::CollisionObjectd>> object;
  std::vector<fcl::AABBd> local_box;  // FCL's own local boxes, before growing
  std::vector<double> local_radius;
  fcl::DynamicAABBTreeCollisionManagerd manager;
  double applied_margin = -1.0;
  bool registered = false;
  double distance_tolerance = 1e-12;
  double touching_gap = 0.0;  // below it, a separated pair is treated as touching
};

FclScene::FclScene(const ContactModel& cmodel) : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  const int n = cmodel.size();
  s.geometry.resize(n);
  s.offset.assign(n, Pose::identity());
  s.object.resize(n);
  s.local_box.resize(n);
  s.local_radius.assign(n, 0.0);

  double largest = 0.0, smallest = std::numeric_limits<double>::infinity();
  for (const Geometry& g : cmodel.geometries)
    if (!isUnbounded(g.shape)) {
      largest = std::max(largest, boundingRadius(g.shape));
      smallest = std::min(smallest, boundingRadius(g.shape));
    }
  // GJK's tolerance is absolute: scale it to the smallest shape (sub-millimetre grains)
  if (std::isfinite(smallest)) {
    s.distance_tolerance = 1e-10 * smallest;
    s.touching_gap = 1e-7 * smallest;
  }

  for (int i = 0; i < n; ++i) {
    const Shape& shape = cmodel.geometries[i].shape;
    switch (shape.type) {
      case ShapeType::Sphere:
      case ShapeType::Disk:  // a disk is the section of a sphere centred in the scene plane
        s.geometry[i] = std::make_shared<fcl::Sphered>(shape.radius);
        break;
      case ShapeType::Box:
        s.geometry[i] = std::make_shared<fcl::Boxd>(2.0 * shape.half_extents);
        break;
      case ShapeType::Cylinder:
        s.geometry[i] = std::make_shared<fcl::Cylinderd>(shape.radius, shape.length);
        break;
      case ShapeType::Capsule:
        s.geometry[i] = std::make_shared<fcl::Capsuled>(shape.radius, shape.length);
        break;
      case ShapeType::Segment: {
        // a rounded segment is a capsule lying in the plane (radius 0 is a bare segment)
        const Vector3 axis = shape.segment_end - shape.segment_start;
        const double length = axis.norm();
        s.geometry[i] = std::make_shared<fcl::Capsuled>(shape.radius, length);
        Pose& o = s.offset[i];
        o.translation = 0.5 * (shape.segment_start + shape.segment_end);
        const Vector3 z = axis / length;
        const Vector3 x = Vector3::UnitZ();
        o.rotation.col(0) = x;
        o.rotation.col(1) = z.cross(x);
        o.rotation.col(2) = z;
        break;
      }
      case ShapeType::Polygon:
        s.geometry[i] = prism(shape.vertices, 10.0 * std::max(largest, boundingRadius(shape)));
        break;
      case ShapeType::ConvexMesh:
        s.geometry[i] = convexMesh(*shape.mesh);
        break;
      case ShapeType::TriangleMesh:
        s.geometry[i] = triangleMesh(*shape.mesh);
        break;
      case ShapeType::HalfSpace:
      case ShapeType::HalfPlane:
        continue;
    }
    s.geometry[i]->computeLocalAABB();
    s.local_box[i] = s.geometry[i]->aabb_local;
    s.local_radius[i] = s.geometry[i]->aabb_radius;
    s.object[i] = std::make_unique<fcl::CollisionObjectd>(s.geometry[i]);
    s.object[i]->setUserData(reinterpret_cast<void*>(static_cast<std::intptr_t>(i)));
  }
}

FclScene::~FclScene() = default;

bool FclScene::has(int geometry) const {
  return impl_->geometry[geometry] != nullptr;
}

void FclScene::update(const std::vector<Pose>& geometry_poses, double margin) {
  Impl& s = *impl_;
  const bool regrow = margin != s.applied_margin;
  for (std::size_t i = 0; i < s.object.size(); ++i) {
    if (!s.object[i]) continue;
    if (regrow) {
      fcl::CollisionGeometryd& g = *s.geometry[i];
      const fcl::Vector3d grow = fcl::Vector3d::Constant(0.5 * margin);
      g.aabb_local = fcl::AABBd(s.local_box[i].min_ - grow, s.local_box[i].max_ + grow);
      g.aabb_radius = s.local_radius[i] + std::sqrt(3.0) * 0.5 * margin;
    }
    const Pose pose = geometry_poses[i] * s.offset[i];
    fcl::Transform3d tf = fcl::Transform3d::Identity();
    tf.linear() = pose.rotation;
    tf.translation() = pose.translation;
    s.object[i]->setTransform(tf);
    s.object[i]->computeAABB();
  }
  s.applied_margin = margin;
  if (s.registered) {
    s.manager.update();
    return;
  }
  // registered at the first real poses, all at once: inserting objects one by one while
  // they all sit at the origin degenerates the tree (quadratic cost)
  std::vector<fcl::CollisionObjectd*> objects;
  for (const auto& object : s.object)
    if (object) objects.push_back(object.get());
  s.manager.registerObjects(objects);
  s.manager.setup();
  s.registered = true;
}

namespace {
bool collectPair(fcl::CollisionObjectd* o1, fcl::CollisionObjectd* o2, void* data) {
  auto* pairs = static_cast<std::vector<std::pair<int, int>>*>(data);
  const int a = static_cast<int>(reinterpret_cast<std::intptr_t>(o1->getUserData()));
  const int b = static_cast<int>(reinterpret_cast<std::intptr_t>(o2->getUserData()));
  pairs->emplace_back(std::min(a, b), std::max(a, b));
  return false;  // keep going
}
// Meshes name the triangles that touch; shape pairs have no primitive, so the contact's rank
// in FCL's answer stands in.
int featureOf(int primitive_a, int primitive_b, int rank) {
  if (primitive_a < 0 && primitive_b < 0) return rank;
  return std::max(primitive_a, 0) * 65536 + std::max(primitive_b, 0);
}
}  // namespace

void FclScene::findPairs(std::vector<std::pair<int, int>>& pairs) {
  impl_->manager.collide(&pairs, collectPair);
}

void FclScene::narrowphase(int a, int b, double margin, std::vector<ContactPoint>& out) const {
  const Impl& s = *impl_;
  const fcl::CollisionObjectd& oa = *s.object[a];
  const fcl::CollisionObjectd& ob = *s.object[b];

  fcl::DistanceRequestd distance_request(true);
  distance_request.distance_tolerance = s.distance_tolerance;
  fcl::DistanceResultd distance_result;
  const double distance = fcl::distance(&oa, &ob, distance_request, distance_result);
  if (distance >= margin) return;
  ContactPoint separated;
  separated.gap = distance;
  separated.point_a = distance_result.nearest_points[0];
  separated.point_b = distance_result.nearest_points[1];
  separated.feature = featureOf(distance_result.b1, distance_result.b2, 0);
  // the normal of a separated pair is the direction between its witness points, which
  // rounding spoils as the gap vanishes; nearly touching pairs take FCL's contact normal
  if (distance > s.touching_gap) {
    separated.normal = (separated.point_b - separated.point_a) / distance;
    out.push_back(separated);
    return;
  }
  // touching or overlapping: FCL reports depth, normal (from a to b) and one point per
  // contact; Sweep's witness points straddle that point along the normal
  fcl::CollisionRequestd collision_request(8, true);
  fcl::CollisionResultd collision_result;
  fcl::collide(&oa, &ob, collision_request, collision_result);
  for (std::size_t k = 0; k < collision_result.numContacts(); ++k) {
    const fcl::Contactd& fc = collision_result.getContact(k);
    ContactPoint c;
    c.gap = -fc.penetration_depth;
    c.normal = fc.normal.normalized();
    c.point_a = fc.pos + 0.5 * fc.penetration_depth * c.normal;
    c.point_b = fc.pos - 0.5 * fc.penetration_depth * c.normal;
    c.feature = featureOf(fc.b1, fc.b2, static_cast<int>(k));
    out.push_back(c);
  }
  if (collision_result.numContacts() > 0 || distance < 0.0) return;
  // Touching within rounding: FCL's collision misses the pair and the witness points are too
  // close to give a direction. Press b into a and take the collision normal: first along the
  // direction from b's centre to its witness point (towards a for a convex shape, exactly
  // along the normal for a ball), then along the normal found, which pressing leaves
  // unchanged, so the second round settles it to rounding.
  Vector3 normal = ob.getTranslation() - separated.point_b;
  if (!(normal.norm() > 0.0)) normal = separated.point_a - oa.getTranslation();
  if (!(normal.norm() > 0.0)) normal = Vector3::UnitX();
  normal.normalize();
  for (int round = 0; round < 2; ++round) {
    fcl::Transform3d pressed = ob.getTransform();
    pressed.translation() -= (distance + (round == 0 ? 10.0 : 2.0) * s.touching_gap) * normal;
    fcl::CollisionResultd pressed_result;
    fcl::collide(oa.collisionGeometry().get(), oa.getTransform(), ob.collisionGeometry().get(),
                 pressed, collision_request, pressed_result);
    if (pressed_result.numContacts() == 0) break;
    normal = pressed_result.getContact(0).normal.normalized();
  }
  separated.normal = normal;
  out.push_back(separated);
}

}  // namespace sweep
