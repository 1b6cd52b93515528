#include "models/rigid_bodies.hpp"

#include <sstream>

#include "framework/error.hpp"

namespace sweep {

namespace {

void requirePositive(const std::string& what, double value) {
  if (!(value > 0.0) || !std::isfinite(value))
    throw InputError("rigid body: " + what + " must be > 0, got " + formatValue(value));
}
}  // namespace

Inertia solidBoxInertia(double mass, const Vector3& size) {
  requirePositive("mass", mass);
  for (int k = 0; k < 3; ++k) requirePositive("box size", size[k]);
  const Vector3 s2 = size.cwiseProduct(size);
  Inertia in;
  in.mass = mass;
  in.inertia_com =
      (mass / 12.0 * Vector3(s2.y() + s2.z(), s2.x() + s2.z(), s2.x() + s2.y())).asDiagonal();
  return in;
}

Inertia solidSphereInertia(double mass, double radius) {
  requirePositive("mass", mass);
  requirePositive("radius", radius);
  Inertia in;
  in.mass = mass;
  in.inertia_com = Matrix3::Identity() * (0.4 * mass * radius * radius);
  return in;
}

Inertia solidDiskInertia(double mass, double radius) {
  requirePositive("mass", mass);
  requirePositive("radius", radius);
  Inertia in;
  in.mass = mass;
  const double i_zz = 0.5 * mass * radius * radius;
  in.inertia_com = Vector3(0.5 * i_zz, 0.5 * i_zz, i_zz).asDiagonal();
  return in;
}

int addPlanarBody(ModelBuilder& builder, const std::string& name, const Inertia& inertia) {
  return builder.addBody(-1, name + "_joint", Joint::planar(), Pose{}, inertia, name);
}

int addFreeBody(ModelBuilder& builder, const std::string& name, const Inertia& inertia) {
  return builder.addBody(-1, name + "_joint", Joint::floating(), Pose{}, inertia, name);
}

}  // namespace sweep
