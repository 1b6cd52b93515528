#pragma once
// The 2D Hall-flowmeter funnel of the seed abstract (../shared/seed/, docs/funnel.md): disks
// dropped from a loose lattice into a funnel whose orifice is closed by a shutter; they compact
// against the walls and the shutter, the shutter is pulled away, and they flow out. One
// builder, reused by the example, the tests, the benchmarks and the `hall_funnel` scene
// generator.
#include <cstdint>

#include "models/scene_spec.hpp"

namespace sweep {

struct FunnelParameters {
  int count = 50;
  double radius_mean = 0.3e-3;  // m
  double radius_std = 0.05;     // standard deviation / mean
  double density = 7800.0;      // kg/m^3: m = rho pi r^2 per unit thickness
  double friction = 0.3;        // grain-grain and grain-wall
  double restitution = 0.0;
  double gravity = 9.81;
  double included_angle = 60.0;   // degrees between the two walls
  double orifice = 2.54e-3;       // m, the Hall orifice
  double shutter_time = 0.03;     // s, when the shutter is pulled away
  double lattice_spacing = 1.15;  // lattice pitch / largest diameter
  std::uint32_t seed = 1;

  void validate() const;  // InputError naming the parameter
};

// Radii from the truncated normal N(mean, (std mean)^2) cut at +-3 standard deviations, then
// the walls (segments from the orifice edges, tall enough that the lattice fits inside the
// cone), the shutter (a segment under the orifice, a driven body removed at shutter_time) and
// the disks on a lattice filling the cone from the shutter up, row by row.
SceneSpec hallFunnel(const FunnelParameters& parameters);

}  // namespace sweep
