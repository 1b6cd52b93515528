#pragma once
// Articulated systems used by examples, tests and benchmarks.
#include "framework/model.hpp"

namespace sweep {

// Planar double pendulum in the world xy plane, gravity -y, revolute joints about z with
// relative angles; point masses m1, m2 at the ends of massless rods l1, l2 (a small rotational
// inertia `tip_inertia` keeps each bob a rigid body). q = 0 hangs straight down.
struct DoublePendulumParameters {
  double m1 = 1.0, m2 = 1.0, l1 = 1.0, l2 = 1.0, g = 10.0;
  double tip_inertia = 0.0;
};
Model doublePendulum(const DoublePendulumParameters& p = {});

// A 6-dof serial arm with rpy joint offsets and full (non-diagonal, off-centre) inertias.
Model serialArm6();

// A branched tree of `n_bodies` revolute joints (binary branching, alternating axes).
Model branchedTree(int n_bodies);

}  // namespace sweep
