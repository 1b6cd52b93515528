#pragma once
// Small scenes shared by the contact tests: bodies carrying one shape each.
#include <random>
#include <vector>

#include "contact/detection.hpp"
#include "framework/kinematics.hpp"
#include "models/rigid_bodies.hpp"
#include "random_draws.hpp"

namespace sweep::test {

// Each shape on its own planar body (2D shapes) or free body (3D shapes), unit mass.
struct ShapeScene {
  Model model;
  std::vector<Shape> shapes;

  ContactModel contactModel(DetectionPathChoice path) const {
    ContactModelBuilder builder(model);
    DetectionSettings settings;
    settings.path = path;
    builder.setSettings(settings);
    for (std::size_t i = 0; i < shapes.size(); ++i)
      builder.addGeometry("shape" + std::to_string(i), BodyRef::dynamic(static_cast<int>(i)),
                          Pose::identity(), shapes[i]);
    return builder.build();
  }
};

inline ShapeScene shapeScene(const std::vector<Shape>& shapes) {
  ModelBuilder builder("shape scene");
  for (std::size_t i = 0; i < shapes.size(); ++i) {
    const std::string name = "body" + std::to_string(i);
    if (isPlanarShape(shapes[i].type))
      addPlanarBody(builder, name, solidDiskInertia(1.0, 1.0));
    else
      addFreeBody(builder, name, solidSphereInertia(1.0, 1.0));
  }
  builder.setGravity(Vector3::Zero());
  return ShapeScene{builder.build(), shapes};
}

// Configuration of body `body` of a shape scene (planar: x, y, theta; free: p, quaternion).
inline void placeBody(const Model& model, VectorX& q, int body, const Vector3& position,
                      const Quaternion& orientation) {
  const int i = model.bodies[body].q_index;
  if (model.bodies[body].joint.type == JointType::Planar) {
    q.segment<2>(i) = position.head<2>();
    q[i + 2] = 2.0 * std::atan2(orientation.z(), orientation.w());
  } else {
    q.segment<3>(i) = position;
    q.segment<4>(i + 3) = orientation.coeffs();
  }
}

inline Quaternion randomOrientation(std::mt19937& rng, bool planar) {
  std::normal_distribution<double> normal;
  if (planar) {
    const double angle = std::uniform_real_distribution<double>(-M_PI, M_PI)(rng);
    return Quaternion(Eigen::AngleAxisd(angle, Vector3::UnitZ()));
  }
  const double z = normal(rng), y = normal(rng), x = normal(rng), w = normal(rng);
  Quaternion r(w, x, y, z);
  return r.normalized();
}

}  // namespace sweep::test
