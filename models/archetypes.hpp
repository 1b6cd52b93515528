#pragma once
// Small systems with known answers (reference section 6), shared by the validation tests,
// the convergence harness (bench/validation_convergence) and docs/validation.md.
#include "models/granular.hpp"

namespace sweep {

// V1, the bouncing ball with the Siconos BouncingBallTS parameters: a sphere of radius r on
// a free body whose centre starts at height drop + r above a floor half-space, at rest,
// frictionless, restitution e. The gap is q[2] - r; its normal in velocity space is v[2].
struct BouncingBallParameters {
  double mass = 1.0;
  double radius = 0.1;
  double drop = 1.0;  // initial gap (m)
  double restitution = 0.9;
  double gravity = 9.81;
};
Scene bouncingBall(const BouncingBallParameters& parameters);

// Analytic impact times of V1: t_1 = sqrt(2 drop / g), t_n = t_1 + (2 v_1 / g) sum_{j<n} e^j.
std::vector<double> bouncingBallImpactTimes(const BouncingBallParameters& parameters, int count);

// V5, Housner's rocking block: a block of width 2b and height 2c (mass m, planar) tilted by
// theta0 (clockwise for theta0 < 0) on its bottom-right corner at the origin, over a floor
// half-plane; e = 0, friction mu. Each corner impact should scale the angular velocity by
// 1 - 3/2 sin^2(s), tan s = b / c, if the impacting corner sticks.
struct RockingBlockParameters {
  double half_width = 0.5;    // b
  double half_height = 0.75;  // c
  double mass = 1.0;
  double friction = 1.0;
  double tilt = -0.1;  // rad
  double gravity = 9.81;
};
Scene rockingBlock(const RockingBlockParameters& parameters);
double housnerRatio(const RockingBlockParameters& parameters);  // 1 - 3/2 sin^2(s)

// V10, a double pendulum hitting a wall: models/kinematic_trees.hpp's doublePendulum (relative
// joint angles, gravity -y) with a bob sphere of radius r at each link's end (solid, so
// I = 2/5 m r^2: the links stay rigid bodies, as in examples/archetypes/double_pendulum.urdf)
// and a wall half-space whose face sits r behind x = 0. The gaps are the reference's
// constraints l1 sin(th1) >= 0 (restitution e_upper) and l1 sin(th1) + l2 sin(th2) >= 0
// (e_lower), th the absolute angles; frictionless.
struct WallPendulumParameters {
  double m1 = 1.0, m2 = 1.0, l1 = 1.0, l2 = 1.0, gravity = 10.0;
  double theta1 = 0.1, theta2 = 0.2;  // absolute angles at rest at t = 0
  double e_upper = 1.0, e_lower = 0.0;
  double bob_radius = 0.02;
};
Scene wallPendulum(const WallPendulumParameters& parameters);

// V11, a slider-crank whose slider sits in its guide with a clearance (Flores, Leine &
// Glocker 2010, "Modeling and analysis of planar rigid multibody systems with translational
// clearance joints based on the non-smooth dynamics approach", Multibody Syst. Dyn. 23):
// crank l1 about the origin, connecting rod l2, and a slider of half-length a and half-width b
// (2a x 2b = 0.10 x 0.05 m, as in the paper and Siconos' example) hinged at the rod's end at
// its centre; the guide is two lines, y = +-(b + clearance), and the
// slider's four corners touch them (e_N, mu). A planar tree of three revolute joints about z
// (relative angles); gravity -y. No drive: the crank starts at omega1 and runs free.
// Absolute angles th = (crank, rod, slider) and their rates at t = 0: th = 0 (crank and rod
// along +x, the slider centred in the guide), omega = (150, -75, -0.01) rad/s, for which
// the slider centre starts with zero vertical speed.
struct SliderCrankParameters {
  double l1 = 0.153, l2 = 0.306;                                // m
  double slider_half_length = 0.05, slider_half_width = 0.025;  // a, b (m)
  double clearance = 0.001;                      // m, between each guide line and the slider
  double m1 = 0.038, m2 = 0.038, m3 = 0.076;     // kg
  double J1 = 7.4e-5, J2 = 5.9e-4, J3 = 2.7e-6;  // kg m^2, about each centre of mass
  Vector3 omega = Vector3(150.0, -75.0, -0.01);  // absolute angular velocities at t = 0
  double restitution = 0.4, friction = 0.01;
  double gravity = 9.81;
};
Scene sliderCrank(const SliderCrankParameters& parameters);

// V9, the woodpecker toy (Pfeiffer & Glocker 1996, "Multibody Dynamics with Unilateral
// Contacts"; the parameters of Glocker's thesis, 1995, as in the Siconos example): a sleeve
// (M) slides down a pole of radius r0 with play (inner radius rM, half-height hM); a bird (S)
// hangs from it on a torsion spring c_phi at horizontal distance lM from the pole axis, its
// centre of mass lG further out, its beak at (-lS, hS) from its centre of mass. Coordinates
// q = (y, phi_M, phi_S - phi_M): a prismatic joint along y, then revolute joints about z at
// the sleeve centre and at the spring (relative angles, so the spring acts on q[2] alone).
// Three contacts, all with the pole's right face x = r0 (mu = 0.3): the beak (e = 0.5) and
// the sleeve's two right inner edges at (rM, +-hM) (e = 0), each a point (a disk of radius
// `point_radius` whose leftmost point is the contact point). Glocker's model is the
// linearization of this one about zero angles: its gaps rM - r0 -+ hM phi_M and
// lM + lG - lS - r0 - hS phi_S are ours to first order; here gravity and inertia keep their
// sines and cosines (the angles reach 0.3 rad, so they differ by a few percent).
struct WoodpeckerParameters {
  double r0 = 0.0025, rM = 0.0031, hM = 0.0058, lM = 0.010, lG = 0.015, hS = 0.02, lS = 0.0201;
  double mM = 0.0003, mS = 0.0045, JM = 5.0e-9, JS = 7.0e-7;
  double c_phi = 0.0056;  // N m / rad
  double gravity = 9.81;
  double e_beak = 0.5, e_sleeve = 0.0, friction = 0.3;
  double point_radius = 1e-5;
  // the Siconos initial state: y, phi_M, phi_S and their rates
  Vector3 q0 = Vector3(0.0, -0.1036, -0.2788);
  Vector3 v0 = Vector3(-0.3411, 0.0, -7.4583);
};
Scene woodpecker(const WoodpeckerParameters& parameters);

}  // namespace sweep
