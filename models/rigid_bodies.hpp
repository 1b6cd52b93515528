#pragma once
// Builders for free rigid bodies: planar (x, y, theta) bodies and free 3D bodies, plus the
// inertias of the usual solids. Bodies with their frame at the centre of mass get a constant
// mass block, so they never rebuild or refactor M.
#include <string>

#include "framework/model.hpp"

namespace sweep {

// Inertia of solids about their centre, in their own axes.
Inertia solidBoxInertia(double mass, const Vector3& size);  // full edge lengths
Inertia solidSphereInertia(double mass, double radius);
// A disk in the xy plane (mass per unit thickness for 2D scenes): I_zz = m r^2 / 2.
Inertia solidDiskInertia(double mass, double radius);

// A body moving in the world xy plane, q = (x, y, theta).
int addPlanarBody(ModelBuilder& builder, const std::string& name, const Inertia& inertia);
// A free 3D body, q = (position, quaternion), v = (world linear velocity, body angular velocity).
int addFreeBody(ModelBuilder& builder, const std::string& name, const Inertia& inertia);

}  // namespace sweep
