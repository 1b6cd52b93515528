#pragma once
// Random vectors drawn in a fixed sequence. The order in which a call's arguments are
// evaluated is the compiler's choice (GCC: right to left, clang: left to right), so
// Vector3(u(rng), u(rng), u(rng)) is another vector under each compiler. These draw z, y, x:
// the order GCC gave, on which the tests' random cases were set.
#include <random>

#include "framework/spatial.hpp"

namespace sweep::test {

template <class Rng, class Distribution>
Vector3 drawVector3(Rng& rng, Distribution& distribution, bool planar = false) {
  const double z = planar ? 0.0 : distribution(rng);
  const double y = distribution(rng);
  const double x = distribution(rng);
  return Vector3(x, y, z);
}

}  // namespace sweep::test
