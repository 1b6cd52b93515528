#pragma once
// One candidate contact at the detection configuration, as the solvers see it.
#include <cstdint>

#include "contact/contact_model.hpp"

namespace sweep {

// Identity of a contact across steps, for warm starts: the geometry pair (a < b) and the
// feature of the pair (a vertex or a triangle for shapes that touch at several points, 0
// for pairs that touch at one).
struct ContactKey {
  int geometry_a = 0;
  int geometry_b = 0;
  int feature = 0;

  bool operator==(const ContactKey& o) const {
    return geometry_a == o.geometry_a && geometry_b == o.geometry_b && feature == o.feature;
  }
  bool operator<(const ContactKey& o) const {
    if (geometry_a != o.geometry_a) return geometry_a < o.geometry_a;
    if (geometry_b != o.geometry_b) return geometry_b < o.geometry_b;
    return feature < o.feature;
  }
};

// Detection writes every field; the vectors carry no default values, so that emitting 10^5
// contacts per step does not write each one twice.
struct Contact {
  ContactKey key;
  BodyRef body_a;
  BodyRef body_b;
  double gap = 0.0;  // signed distance; < 0 when overlapping
  Vector3 normal;    // unit, world, from a towards b
  Vector3 tangent1;  // world, orthonormal to the normal
  Vector3 tangent2;  // 3D: normal x tangent1; 2D: zero
  Vector3 point_a;   // world witness point on a
  // world witness point on b: point_a + gap * normal, less one period when the pair meets
  // b's periodic image (key.feature 1: image at +period, 2: at -period)
  Vector3 point_b;
  double friction = 0.0;
  double restitution = 0.0;
  double rolling = 0.0;  // mu_r R*: the rolling torque bound per unit normal impulse
  int previous = -1;     // index of the same contact in the previous detection, or -1
};

}  // namespace sweep
