#pragma once
#include <functional>
// Granular test scenes: polydisperse disks (2D) or spheres (3D) in an open box, filled from
// a loose lattice. One builder, reused by tests and benchmarks.
#include <cstdint>

#include "contact/contact_model.hpp"

namespace sweep {

// A model with its contact model and initial state.
struct Scene {
  Model model;
  ContactModel cmodel;
  VectorX q0;
  VectorX v0;
  // applied generalized forces tau(t, q, v) besides gravity (the scene's loads); empty if none
  std::function<void(double t, const VectorX& q, const VectorX& v, VectorX& tau)> forces;
};

struct GranularBoxParameters {
  int count = 200;
  bool planar = true;          // disks in the xy plane, or spheres
  double radius = 1e-3;        // mean radius
  double radius_spread = 0.2;  // radii uniform in radius * [1 - spread, 1 + spread]
  double density = 7800.0;     // kg/m^3 (2D: mass per unit thickness)
  double width = 0.04;         // box width (x; and z for spheres)
  double friction = 0.3;
  double restitution = 0.0;
  double gravity = 9.81;
  std::uint32_t seed = 1;
};

// Grains on a lattice of pitch 2.2 * max radius above a floor, between two walls (2D) or four
// walls (3D), all half-planes / half-spaces; gravity along -y.
Scene granularBox(const GranularBoxParameters& parameters);

}  // namespace sweep
