#include "models/granular.hpp"

#include <cmath>
#include <random>

#include "framework/error.hpp"
#include "models/rigid_bodies.hpp"

namespace sweep {

Scene granularBox(const GranularBoxParameters& p) {
  if (p.count < 1 || !(p.radius > 0.0) || !(p.width > 4.4 * p.radius) ||
      !(p.radius_spread >= 0.0 && p.radius_spread < 1.0) || !(p.density > 0.0))
    throw InputError("granularBox: invalid parameters");
  std::mt19937 rng(p.seed);
  std::uniform_real_distribution<double> spread(1.0 - p.radius_spread, 1.0 + p.radius_spread);
  std::vector<double> radii(p.count);
  for (double& r : radii) r = p.radius * spread(rng);

  Scene scene;
  ModelBuilder mb("granular box");
  for (int i = 0; i < p.count; ++i) {
    const double r = radii[i];
    const std::string name = "grain" + std::to_string(i);
    if (p.planar)
      addPlanarBody(mb, name, solidDiskInertia(p.density * M_PI * r * r, r));
    else
      addFreeBody(mb, name, solidSphereInertia(p.density * 4.0 / 3.0 * M_PI * r * r * r, r));
  }
  mb.setGravity(Vector3(0, -p.gravity, 0));
  scene.model = mb.build();

  ContactModelBuilder cb(scene.model);
  cb.materials().setDefaultLaw({p.friction, p.restitution});
  for (int i = 0; i < p.count; ++i)
    cb.addGeometry("grain" + std::to_string(i), BodyRef::dynamic(i), Pose::identity(),
                   p.planar ? Shape::disk(radii[i]) : Shape::sphere(radii[i]));
  // half-spaces with outward normals into the box: floor y = 0, walls at 0 and width
  auto wall = [&](const std::string& name, const Vector3& point, const Vector3& inward) {
    Pose pose;
    pose.translation = point;
    const Vector3 local_normal = p.planar ? Vector3::UnitY() : Vector3::UnitZ();
    pose.rotation = Eigen::Quaterniond::FromTwoVectors(local_normal, inward).toRotationMatrix();
    if (p.planar) {
      // keep the half-plane's z axis on the scene normal
      const Vector3 y = inward.normalized();
      pose.rotation.col(0) = y.cross(Vector3::UnitZ());
      pose.rotation.col(1) = y;
      pose.rotation.col(2) = Vector3::UnitZ();
    }
    cb.addGeometry(name, BodyRef::world(), pose,
                   p.planar ? Shape::halfPlane() : Shape::halfSpace());
  };
  wall("floor", Vector3::Zero(), Vector3::UnitY());
  wall("left", Vector3::Zero(), Vector3::UnitX());
  wall("right", Vector3(p.width, 0, 0), -Vector3::UnitX());
  if (!p.planar) {
    wall("back", Vector3::Zero(), Vector3::UnitZ());
    wall("front", Vector3(0, 0, p.width), -Vector3::UnitZ());
  }
  scene.cmodel = cb.build();

  // loose lattice, row by row from the floor up
  const double pitch = 2.2 * p.radius * (1.0 + p.radius_spread);
  const int per_row = static_cast<int>(std::floor(p.width / pitch));
  const int per_layer = p.planar ? per_row : per_row * per_row;
  std::uniform_real_distribution<double> jitter(-0.05 * pitch, 0.05 * pitch);
  scene.q0 = scene.model.neutralConfiguration();
  scene.v0 = VectorX::Zero(scene.model.nv);
  for (int i = 0; i < p.count; ++i) {
    const int layer = i / per_layer, in_layer = i % per_layer;
    const double x = pitch * (0.5 + in_layer % per_row) + jitter(rng);
    const double y = pitch * (0.5 + layer);
    const int qi = scene.model.bodies[i].q_index;
    scene.q0[qi] = x;
    scene.q0[qi + 1] = y;
    if (!p.planar) scene.q0[qi + 2] = pitch * (0.5 + in_layer / per_row) + jitter(rng);
  }
  return scene;
}

}  // namespace sweep
