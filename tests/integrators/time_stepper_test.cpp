// Both NSCD schemes on small systems with exact answers (reference sections 5 and 6).
#include "integrators/time_stepper.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <optional>

#include "framework/configuration.hpp"
#include "framework/kinematics.hpp"
#include "models/granular.hpp"
#include "models/rigid_bodies.hpp"
#include "solver_fixtures.hpp"

namespace sweep {
namespace {

class BothSchemes : public ::testing::TestWithParam<Scheme> {
 protected:
  SchemeSettings settings(double h) const {
    SchemeSettings s;
    s.scheme = GetParam();
    s.h = h;
    s.coulomb.tolerance = s.normal_stage.tolerance = s.friction_stage.tolerance = 1e-12;
    return s;
  }
};

// A sphere of radius r on a free body above a floor half-space.
struct BallOnFloor {
  Model model;
  ContactModel cmodel;
  BallOnFloor(double mass, double radius, double mu, double e, const Vector3& gravity) {
    ModelBuilder mb("ball on floor");
    addFreeBody(mb, "ball", solidSphereInertia(mass, radius));
    mb.setGravity(gravity);
    model = mb.build();
    ContactModelBuilder cb(model);
    cb.materials().setDefaultLaw({mu, e});
    cb.addGeometry("ball", BodyRef::dynamic(0), Pose::identity(), Shape::sphere(radius));
    cb.addGeometry("floor", BodyRef::world(), Pose::identity(), Shape::halfSpace());
    cmodel = cb.build();
  }
  VectorX at(double height) const {
    VectorX q = model.neutralConfiguration();
    q[2] = height;
    return q;
  }
};

// At rest on a plane: the impulse is m g h every step, and nothing drifts.
TEST_P(BothSchemes, BallAtRestOnAPlane) {
  const double m = 2.0, r = 0.1, g = 9.81, h = 1e-3;
  const BallOnFloor scene(m, r, 0.5, 0.0, Vector3(0, 0, -g));
  TimeStepper stepper(scene.model, scene.cmodel, settings(h));
  stepper.reset(0.0, scene.at(r), VectorX::Zero(6));
  for (int k = 0; k < 100000; ++k) {
    const StepStats& s = stepper.step();
    ASSERT_EQ(s.active, 1) << "step " << k;
    if (k > 0) {
      // warm started from the exact impulse: converged in the first sweep
      ASSERT_LE(s.iterations_stage1, 1) << "step " << k;
    }
  }
  EXPECT_NEAR(stepper.impulses()[0].x(), m * g * h, 1e-12 * m * g * h);
  EXPECT_LT(std::abs(stepper.q()[2] - r), 1e-12);
  EXPECT_LT(stepper.v().norm(), 1e-12);
}

// A point mass (two prismatic joints, no rotation) on an incline of angle a: sticks exactly
// when tan a <= mu, slides with g (sin a - mu cos a) otherwise.
struct PointMassOnIncline {
  Model model;
  ContactModel cmodel;
  double angle;
  PointMassOnIncline(double a, double mu) : angle(a) {
    ModelBuilder mb("point mass on incline");
    const int carriage =
        mb.addBody(-1, "x", Joint::prismatic(Vector3::UnitX()), Pose{}, Inertia{}, "carriage");
    mb.addBody(carriage, "y", Joint::prismatic(Vector3::UnitY()), Pose{},
               Inertia{1.5, Vector3::Zero(), Matrix3::Identity() * 1e-3}, "mass");
    mb.setGravity(Vector3(0, -9.81, 0));
    model = mb.build();
    ContactModelBuilder cb(model);
    cb.materials().setDefaultLaw({mu, 0.0});
    cb.addGeometry("mass", BodyRef::dynamic(model.bodyIndex("mass")), Pose::identity(),
                   Shape::disk(0.05));
    Pose slope;
    slope.rotation = Eigen::AngleAxisd(a, Vector3::UnitZ()).toRotationMatrix();
    cb.addGeometry("slope", BodyRef::world(), slope, Shape::halfPlane());
    cmodel = cb.build();
  }
  // resting on the slope, `along` down the slope from the origin
  VectorX at(double along) const {
    const Vector3 down(-std::cos(angle), -std::sin(angle), 0.0);
    const Vector3 up_normal(-std::sin(angle), std::cos(angle), 0.0);
    const Vector3 p = along * down + 0.05 * up_normal;
    VectorX q(2);
    q << p.x(), p.y();
    return q;
  }
  double along(const VectorX& q) const {
    return -(q[0] * std::cos(angle) + q[1] * std::sin(angle));
  }
};

TEST_P(BothSchemes, PointMassSticksOnIncline) {
  const double mu = 0.5;
  const PointMassOnIncline scene(0.99 * std::atan(mu), mu);
  TimeStepper stepper(scene.model, scene.cmodel, settings(1e-3));
  stepper.reset(0.0, scene.at(0.0), VectorX::Zero(2));
  for (int k = 0; k < 100000; ++k) stepper.step();
  EXPECT_LT(std::abs(scene.along(stepper.q())), 1e-12);
}

TEST_P(BothSchemes, PointMassSlidesWithCoulombAcceleration) {
  const double mu = 0.3, a = 0.5, g = 9.81, h = 1e-3;
  const PointMassOnIncline scene(a, mu);
  TimeStepper stepper(scene.model, scene.cmodel, settings(h));
  stepper.reset(0.0, scene.at(0.0), VectorX::Zero(2));
  // from the second step on the contact is closed (the first may start at a gap of +1e-17)
  for (int k = 0; k < 10; ++k) stepper.step();
  const double s0 = scene.along(stepper.q());
  const Vector3 down(-std::cos(a), -std::sin(a), 0.0);
  const double v0 = down.head<2>().dot(stepper.v());
  const int steps = 1000;
  for (int k = 0; k < steps; ++k) stepper.step();
  const double acceleration = g * (std::sin(a) - mu * std::cos(a));
  const double T = steps * h;
  // the midpoint rule integrates a constant acceleration exactly
  EXPECT_NEAR(down.head<2>().dot(stepper.v()), v0 + acceleration * T, 1e-9 * acceleration * T);
  EXPECT_NEAR(scene.along(stepper.q()) - s0, v0 * T + 0.5 * acceleration * T * T,
              1e-9 * acceleration * T * T);
  EXPECT_NEAR(v0, acceleration * 10 * h, 1e-9);
}

// Bouncing ball: at every impact step U_N(k+1) = -e U_N(k), and the energy balance
// E(k+1) - E(k) = contact work holds to round-off (constant M, gravity).
TEST_P(BothSchemes, BouncingBallRestitutionAndEnergyIdentity) {
  const double e = 0.9, h = 1e-3;
  const BallOnFloor scene(1.0, 0.1, 0.0, e, Vector3(0, 0, -9.81));
  TimeStepper stepper(scene.model, scene.cmodel, settings(h));
  stepper.reset(0.0, scene.at(1.0), VectorX::Zero(6));
  int impacts = 0;
  double energy = stepper.energy();
  for (int k = 0; k < 5000; ++k) {
    const double vz_before = stepper.v()[2];
    const StepStats& s = stepper.step();
    const double next_energy = s.kinetic + s.potential;
    EXPECT_NEAR(next_energy - energy, s.work_normal + s.work_tangent, 1e-12 * std::abs(energy))
        << "step " << k;
    energy = next_energy;
    if (s.active == 1 && stepper.impulses()[0].x() > 0.0) {
      ++impacts;
      EXPECT_NEAR(stepper.v()[2], -e * vz_before, 1e-12) << "step " << k;
      EXPECT_LE(s.work_normal, 1e-15);
    }
  }
  EXPECT_GE(impacts, 5);
}

// V1 with the Siconos parameters (q0 = 1, e = 0.9, g = 9.81, h = 0.005): the n-th impact
// step lies within n h of the analytic impact time t_n = t1 + (2 v1 / g) sum_{j<n} e^j.
TEST_P(BothSchemes, BouncingBallImpactTimes) {
  const double e = 0.9, g = 9.81, h = 0.005, r = 0.1;
  const BallOnFloor scene(1.0, r, 0.0, e, Vector3(0, 0, -g));
  TimeStepper stepper(scene.model, scene.cmodel, settings(h));
  stepper.reset(0.0, scene.at(1.0 + r), VectorX::Zero(6));
  std::vector<double> impacts;
  while (stepper.time() < 3.5) {
    const double vz = stepper.v()[2];
    stepper.step();
    // an impact step: the contact reverses a falling velocity
    if (vz < -0.5 && stepper.v()[2] > 0.0) impacts.push_back(stepper.time() - 0.5 * h);
  }
  ASSERT_GE(impacts.size(), 5u);
  const double t1 = std::sqrt(2.0 / g), v1 = g * t1;
  double t_n = t1, sum = 0.0;
  for (std::size_t n = 0; n < 5; ++n) {
    if (n > 0) {
      sum += std::pow(e, static_cast<double>(n));
      t_n = t1 + 2.0 * v1 / g * sum;
    }
    EXPECT_NEAR(impacts[n], t_n, (n + 1) * h) << "impact " << n + 1;
  }
}

// V2b: a block sliding on an incline on two corners. A and B (GLOBAL) reproduce the sliding
// acceleration g (sin a - mu cos a) with no penetration drift; B with LOCAL tangents and VEL
// lets the corners sink, linearly in time (reference 4.7; the slope is printed).
TEST(BlockOnIncline, TwoCornerSliding) {
  const double a = 0.4, mu = 0.2, g = 9.81, h = 1e-3;
  ModelBuilder mb("block on incline");
  addPlanarBody(mb, "block", solidBoxInertia(1.0, Vector3(0.4, 0.2, 0.01)));
  mb.setGravity(Vector3(0, -g, 0));
  const Model model = mb.build();
  ContactModelBuilder cb(model);
  cb.materials().setDefaultLaw({mu, 0.0});
  cb.addGeometry("block", BodyRef::dynamic(0), Pose::identity(),
                 Shape::polygon({{-0.2, -0.1}, {0.2, -0.1}, {0.2, 0.1}, {-0.2, 0.1}}));
  Pose slope;
  slope.rotation = Eigen::AngleAxisd(a, Vector3::UnitZ()).toRotationMatrix();
  cb.addGeometry("slope", BodyRef::world(), slope, Shape::halfPlane());
  const ContactModel cmodel = cb.build();
  ASSERT_EQ(cmodel.path, DetectionPath::Analytic);
  const Vector3 up_normal(-std::sin(a), std::cos(a), 0.0);
  const Vector3 down(-std::cos(a), -std::sin(a), 0.0);
  VectorX q(3);
  q << 0.1 * up_normal.x(), 0.1 * up_normal.y(), a;

  struct Case {
    Scheme scheme;
    TangentMode tangents;
  };
  for (const Case& run : {Case{Scheme::MoreauJean, TangentMode::Global},
                          Case{Scheme::CatchingUp, TangentMode::Global},
                          Case{Scheme::CatchingUp, TangentMode::Local}}) {
    SchemeSettings s;
    s.scheme = run.scheme;
    s.h = h;
    s.friction.tangents = run.tangents;
    s.coulomb.tolerance = s.normal_stage.tolerance = s.friction_stage.tolerance = 1e-12;
    TimeStepper stepper(model, cmodel, s);
    stepper.reset(0.0, q, VectorX::Zero(3));
    for (int k = 0; k < 10; ++k) stepper.step();
    const double v0 = down.head<2>().dot(stepper.v().head<2>());
    const double pen0 = stepper.stats().penetration_max;
    const int steps = 1000;
    for (int k = 0; k < steps; ++k) stepper.step();
    const double v1 = down.head<2>().dot(stepper.v().head<2>());
    const double pen1 = stepper.stats().penetration_max;
    const std::string name = std::string(enumName(run.scheme)) + " " + enumName(run.tangents);
    if (run.tangents == TangentMode::Global) {
      EXPECT_NEAR((v1 - v0) / (steps * h), g * (std::sin(a) - mu * std::cos(a)), 1e-6) << name;
      // the first free-fall step leaves a dip of order h^2 g, which VEL keeps; it must not grow
      EXPECT_NEAR(pen1, pen0, 1e-12) << name;
    } else {
      std::printf("V2b %s: penetration %.3g m after %.1f s, drift slope %.3g m/s\n", name.c_str(),
                  pen1, (steps + 10) * h, (pen1 - pen0) / (steps * h));
      EXPECT_GT(pen1, pen0) << name << ": the drift the reference predicts";
    }
  }
}

// Mean acceleration of a body's origin along `down` (first 3 velocity components of a free
// body, first 2 of a planar one, projected), over 500 steps after 10 steps of settling.
double slopeAcceleration(const Model& model, const ContactModel& cmodel, const VectorX& q,
                         const Vector3& down, Scheme scheme, FrictionThreshold threshold,
                         double h) {
  SchemeSettings s;
  s.scheme = scheme;
  s.h = h;
  s.friction.threshold = threshold;
  s.coulomb.tolerance = s.normal_stage.tolerance = s.friction_stage.tolerance = 1e-12;
  TimeStepper stepper(model, cmodel, s);
  stepper.reset(0.0, q, VectorX::Zero(model.nv));
  const bool planar = model.bodies[0].joint.type == JointType::Planar;
  auto along = [&] {
    const VectorX& v = stepper.v();
    return planar ? down.head<2>().dot(v.head<2>()) : down.dot(v.head<3>());
  };
  for (int k = 0; k < 10; ++k) stepper.step();
  const double v0 = along();
  for (int k = 0; k < 500; ++k) stepper.step();
  return (along() - v0) / (500 * h);
}

// V4: a solid disk on an incline rolls without slip iff mu >= tan(a) / 3. With tan a = 0.6
// and mu = 0.25 it rolls: a_G = 2/3 g sin a, for A and for B with the PHYSICAL threshold
// (W_NT = 0). The METRIC threshold bounds |lambda_T| by mu lambda_N sqrt(W_NN / W_TT), i.e.
// mu / sqrt(1 + m R^2 / I) = mu / sqrt(3): the rolling condition becomes mu >= tan(a) /
// sqrt(3) = 0.35, and the disk slides with g (sin a - mu / sqrt(3) cos a). It changes
// Coulomb's classical threshold.
TEST(DiskOnIncline, RollingThresholdSeparatesTheFrictionThresholds) {
  const double a = std::atan(0.6), mu = 0.25, g = 9.81, h = 1e-3, R = 0.1;
  ModelBuilder mb("disk on incline");
  addPlanarBody(mb, "disk", solidDiskInertia(1.0, R));
  mb.setGravity(Vector3(0, -g, 0));
  const Model model = mb.build();
  ContactModelBuilder cb(model);
  cb.materials().setDefaultLaw({mu, 0.0});
  cb.addGeometry("disk", BodyRef::dynamic(0), Pose::identity(), Shape::disk(R));
  Pose slope;
  slope.rotation = Eigen::AngleAxisd(a, Vector3::UnitZ()).toRotationMatrix();
  cb.addGeometry("slope", BodyRef::world(), slope, Shape::halfPlane());
  const ContactModel cmodel = cb.build();
  const Vector3 up_normal(-std::sin(a), std::cos(a), 0.0);
  const Vector3 down(-std::cos(a), -std::sin(a), 0.0);
  VectorX q(3);
  q << R * up_normal.x(), R * up_normal.y(), 0.0;

  auto acceleration = [&](Scheme scheme, FrictionThreshold threshold) {
    return slopeAcceleration(model, cmodel, q, down, scheme, threshold, h);
  };
  const double rolling = 2.0 / 3.0 * g * std::sin(a);
  const double metric_sliding = g * (std::sin(a) - mu / std::sqrt(3.0) * std::cos(a));
  EXPECT_NEAR(acceleration(Scheme::MoreauJean, FrictionThreshold::Physical), rolling, 1e-9);
  EXPECT_NEAR(acceleration(Scheme::CatchingUp, FrictionThreshold::Physical), rolling, 1e-9);
  EXPECT_NEAR(acceleration(Scheme::CatchingUp, FrictionThreshold::Metric), metric_sliding, 1e-9);
}

// V4 in 3D: a solid sphere rolls iff mu >= 2/7 tan a (0.171 at tan a = 0.6); the METRIC
// bound, mu / sqrt(1 + m R^2 / I) = mu / sqrt(3.5), moves it to 0.32. With mu = 0.25: A and
// B PHYSICAL roll at 5/7 g sin a; B METRIC slides at g (sin a - mu / sqrt(3.5) cos a).
TEST(SphereOnIncline, RollingThresholdIn3d) {
  const double a = std::atan(0.6), mu = 0.25, g = 9.81, h = 1e-3, R = 0.1;
  ModelBuilder mb("sphere on incline");
  addFreeBody(mb, "ball", solidSphereInertia(1.0, R));
  mb.setGravity(Vector3(0, 0, -g));
  const Model model = mb.build();
  ContactModelBuilder cb(model);
  cb.materials().setDefaultLaw({mu, 0.0});
  cb.addGeometry("ball", BodyRef::dynamic(0), Pose::identity(), Shape::sphere(R));
  Pose slope;  // tilted about y: downhill is -x
  slope.rotation = Eigen::AngleAxisd(-a, Vector3::UnitY()).toRotationMatrix();
  cb.addGeometry("slope", BodyRef::world(), slope, Shape::halfSpace());
  const ContactModel cmodel = cb.build();
  const Vector3 normal = slope.rotation.col(2);
  const Vector3 down = -slope.rotation.col(0);
  VectorX q = model.neutralConfiguration();
  q.head<3>() = R * normal;

  auto acceleration = [&](Scheme scheme, FrictionThreshold threshold) {
    return slopeAcceleration(model, cmodel, q, down, scheme, threshold, h);
  };
  const double rolling = 5.0 / 7.0 * g * std::sin(a);
  const double metric_sliding = g * (std::sin(a) - mu / std::sqrt(3.5) * std::cos(a));
  EXPECT_NEAR(acceleration(Scheme::MoreauJean, FrictionThreshold::Physical), rolling, 1e-9);
  EXPECT_NEAR(acceleration(Scheme::CatchingUp, FrictionThreshold::Physical), rolling, 1e-9);
  EXPECT_NEAR(acceleration(Scheme::CatchingUp, FrictionThreshold::Metric), metric_sliding, 1e-9);
}

// V5, Housner's rocking block: width 2b = 1, height 2c = 1.5, corners sticking (mu = 1),
// e = 0. Each corner impact multiplies the angular velocity by 1 - 3/2 sin^2(s),
// tan s = b / c: 0.5385. The tolerance, 1 %, covers what gravity adds to omega within the
// impact step (about 0.1 % at h = 1e-4) and the pre-impact rotation at the midpoint.
TEST_P(BothSchemes, RockingBlockHousnerRatio) {
  const double b = 0.5, c = 0.75, h = 1e-4, theta0 = -0.1;
  ModelBuilder mb("rocking block");
  addPlanarBody(mb, "block", solidBoxInertia(1.0, Vector3(2 * b, 2 * c, 0.01)));
  mb.setGravity(Vector3(0, -9.81, 0));
  const Model model = mb.build();
  ContactModelBuilder cb(model);
  cb.materials().setDefaultLaw({1.0, 0.0});
  cb.addGeometry("block", BodyRef::dynamic(0), Pose::identity(),
                 Shape::polygon({{-b, -c}, {b, -c}, {b, c}, {-b, c}}));
  cb.addGeometry("floor", BodyRef::world(), Pose::identity(), Shape::halfPlane());
  const ContactModel cmodel = cb.build();
  // tilted clockwise on its bottom-right corner, which sits at the origin
  const Eigen::Rotation2Dd R(theta0);
  const Vector2 centre = -(R * Vector2(b, -c));
  VectorX q(3);
  q << centre.x(), centre.y(), theta0;
  TimeStepper stepper(model, cmodel, settings(h));
  stepper.reset(0.0, q, VectorX::Zero(3));
  const double s = std::atan(b / c);
  const double expected = 1.0 - 1.5 * std::sin(s) * std::sin(s);
  int impacts = 0;
  for (int k = 0; k < 40000 && impacts < 2; ++k) {
    const double before = stepper.v()[2];
    stepper.step();
    const double after = stepper.v()[2];
    if (std::abs(before) > 0.05 && std::abs(after) < 0.8 * std::abs(before)) {
      EXPECT_NEAR(after / before, expected, 0.01) << "impact " << impacts + 1;
      std::printf("V5 %s impact %d: omega+/omega- = %.4f (Housner %.4f)\n", enumName(GetParam()),
                  impacts + 1, after / before, expected);
      ++impacts;
    }
  }
  EXPECT_EQ(impacts, 2);
}

// Several balls sliding and spinning on a rough floor, one contact each (W_NT = 0, e = 0):
// both schemes solve the same Coulomb problem.
TEST(SchemesAgree, DecoupledContacts) {
  ModelBuilder mb("balls");
  for (int i = 0; i < 4; ++i)
    addFreeBody(mb, "ball" + std::to_string(i), solidSphereInertia(1.0 + i, 0.1));
  mb.setGravity(Vector3(0, 0, -9.81));
  const Model model = mb.build();
  ContactModelBuilder cb(model);
  cb.materials().setDefaultLaw({0.3, 0.0});
  for (int i = 0; i < 4; ++i)
    cb.addGeometry("ball" + std::to_string(i), BodyRef::dynamic(i), Pose::identity(),
                   Shape::sphere(0.1));
  cb.addGeometry("floor", BodyRef::world(), Pose::identity(), Shape::halfSpace());
  const ContactModel cmodel = cb.build();
  VectorX q = model.neutralConfiguration(), v = VectorX::Zero(model.nv);
  for (int i = 0; i < 4; ++i) {
    q.segment<3>(7 * i) = Vector3(1.0 * i, 0.0, 0.1);
    v.segment<6>(6 * i) << 1.0 - 0.5 * i, 0.3 * i, -0.2, 5.0 * i, -3.0, 2.0;
  }
  std::vector<VectorX> end;
  for (Scheme scheme : {Scheme::MoreauJean, Scheme::CatchingUp}) {
    SchemeSettings s;
    s.scheme = scheme;
    s.h = 1e-3;
    s.coulomb.tolerance = s.normal_stage.tolerance = s.friction_stage.tolerance = 1e-13;
    TimeStepper stepper(model, cmodel, s);
    stepper.reset(0.0, q, v);
    for (int k = 0; k < 500; ++k) stepper.step();
    end.push_back(stepper.v());
  }
  EXPECT_LT((end[0] - end[1]).norm(), 1e-9);
}

// A pendulum swinging into its lower joint limit (e = 0): the limit is a unilateral row of
// the same solve. VEL lets it overshoot by at most the impact step's (h/2) |omega|; POS holds
// it at the bound up to round-off.
TEST_P(BothSchemes, JointLimitStopsAPendulum) {
  ModelBuilder mb("limited pendulum");
  Inertia bob{1.0, Vector3(0, -1, 0), Matrix3::Identity() * 1e-4};
  const int rod = mb.addBody(-1, "hinge", Joint::revolute(Vector3::UnitZ()), Pose{}, bob, "rod");
  mb.addJointLimits(rod, -0.3, 0.3);
  mb.setGravity(Vector3(0, -9.81, 0));
  const Model model = mb.build();
  const ContactModel cmodel = ContactModelBuilder(model).build();
  for (NormalLaw law : {NormalLaw::Vel, NormalLaw::Pos}) {
    SchemeSettings s = settings(1e-3);
    s.normal_law = law;
    TimeStepper stepper(model, cmodel, s);
    stepper.reset(0.0, VectorX::Zero(1), VectorX::Constant(1, -1.0));
    double lowest = 0.0, fastest = 0.0, impulse = 0.0;
    for (int k = 0; k < 2000; ++k) {
      fastest = std::max(fastest, std::abs(stepper.v()[0]));
      stepper.step();
      lowest = std::min(lowest, stepper.q()[0]);
      impulse = std::max(impulse, stepper.limitImpulses()[0]);
    }
    EXPECT_GT(impulse, 0.0) << enumName(law);
    // free swing would reach acos(1 - 1 / (2 g)) = 0.32 rad
    EXPECT_LT(lowest, -0.3 + 1e-9) << enumName(law);
    const double overshoot = law == NormalLaw::Vel ? 0.5 * s.h * fastest + 1e-12 : 1e-12;
    EXPECT_GT(lowest, -0.3 - overshoot) << enumName(law);
    EXPECT_LE(stepper.q()[0], 0.3 + overshoot);
  }
}

// A sphere starting 1 mm into the floor at rest, and one about to land: what each normal
// law does with the gap (reference 1.4).
TEST_P(BothSchemes, NormalLawsAndGaps) {
  const double r = 0.1, h = 1e-3;
  const BallOnFloor scene(1.0, r, 0.0, 0.0, Vector3(0, 0, -9.81));
  for (NormalLaw law : {NormalLaw::Vel, NormalLaw::Iqs, NormalLaw::Pos}) {
    SchemeSettings s = settings(h);
    s.normal_law = law;
    TimeStepper stepper(scene.model, scene.cmodel, s);
    stepper.reset(0.0, scene.at(r - 1e-3), VectorX::Zero(6));
    stepper.step();
    if (law == NormalLaw::Pos) {
      // g(q_m) + h/2 U_N >= 0 is exact for a plane: pushed out in one step, at the price of
      // an upward velocity g / (h/2): POS injects energy into penetrated contacts
      EXPECT_NEAR(stepper.q()[2] - r, 0.0, 1e-12) << enumName(law);
      EXPECT_NEAR(stepper.v()[2], 1e-3 / (0.5 * h), 1e-9);
    } else {
      // VEL and IQS never push out an existing penetration (no energy injected)
      for (int k = 0; k < 20; ++k) stepper.step();
      EXPECT_NEAR(stepper.q()[2] - r, -1e-3, 1e-12) << enumName(law);
    }
    // landing at 1 m/s, 0.3 mm above the floor at the midpoint of the first step
    VectorX v = VectorX::Zero(6);
    v[2] = -1.0;
    stepper.reset(0.0, scene.at(r + 8e-4), v);
    stepper.step();
    const double first = stepper.q()[2] - r;
    if (law == NormalLaw::Vel) {
      // VEL activates only once g(q_m) <= 0: the first step lands 0.2 mm inside
      EXPECT_NEAR(first, 3e-4 - 0.5 * h * (1.0 + 9.81 * h), 1e-12);
    } else {
      // IQS and POS close the 0.3 mm midpoint gap exactly at the end of the step
      EXPECT_NEAR(first, 0.0, 1e-12) << enumName(law);
    }
    // next step: the explicit midpoint q_m = q_k + h/2 v_k dips (h/2) 0.6 m/s = 0.3 mm into
    // the floor; POS pushes that out at 0.6 m/s, a bounce from an inelastic contact (the
    // energy POS injects, docs/schemes.md); VEL and IQS keep the dip
    stepper.step();
    if (law == NormalLaw::Pos) {
      EXPECT_NEAR(stepper.v()[2], 0.6, 1e-9);
    } else {
      EXPECT_NEAR(stepper.v()[2], 0.0, 1e-9) << enumName(law);
    }
  }
}

// A ball released at rest 1 mm above the floor with h = 0.02 s: the margin from the start
// speed is the floor (0.1 mm), but the ball falls 2 mm by the end of the step. Unchecked, the
// floor is not a candidate and the ball ends 1 mm inside it; detection.verify_margin sees the
// end speed outrun the margin, detects again, and IQS lands the ball on the floor.
TEST_P(BothSchemes, VerifiedMarginCatchesAContactTheStartSpeedMissed) {
  const double r = 0.1, h = 0.02, g = 9.81, gap = 1e-3;
  BallOnFloor scene(1.0, r, 0.5, 0.0, Vector3(0, 0, -g));
  ASSERT_LT(scene.cmodel.margin_floor, gap);
  for (bool verify : {false, true}) {
    scene.cmodel.settings.verify_margin = verify;
    SchemeSettings s = settings(h);
    s.normal_law = NormalLaw::Iqs;
    TimeStepper stepper(scene.model, scene.cmodel, s);
    stepper.reset(0.0, scene.at(r + gap), VectorX::Zero(6));
    const StepStats& st = stepper.step();
    const double end_gap = stepper.q()[2] - r;
    if (verify) {
      EXPECT_EQ(st.redetections, 1);
      EXPECT_FALSE(st.margin_outrun);
      EXPECT_EQ(st.active, 1);
      EXPECT_NEAR(end_gap, 0.0, 1e-12);
      EXPECT_GT(st.margin, h * g * h);  // the end speed's reach
    } else {
      EXPECT_EQ(st.redetections, 0);
      EXPECT_EQ(st.active, 0);
      EXPECT_NEAR(end_gap, gap - 0.5 * h * g * h, 1e-12);
    }
  }
  // VEL solves closed contacts only: the margin decides nothing, and nothing is redone
  scene.cmodel.settings.verify_margin = true;
  SchemeSettings s = settings(h);
  s.normal_law = NormalLaw::Vel;
  TimeStepper stepper(scene.model, scene.cmodel, s);
  stepper.reset(0.0, scene.at(r + gap), VectorX::Zero(6));
  EXPECT_EQ(stepper.step().redetections, 0);
}

// detection.margin_rule: relative. A wall moving at 1 m/s touches ball A, which rests 1 mm
// from ball B: at the start both balls rest, so their pair gets the floor as its margin and
// is no candidate, but the wall sets A moving at 1 m/s and it would close 5 mm on B by the end
// of the step. The check sees the balls' end velocities outrun their margin, detects again,
// and IQS stops A at B. The absolute rule takes the wall's speed for every pair and needs no
// second detection.
TEST_P(BothSchemes, RelativeMarginCatchesARestingPairSetMovingWithinTheStep) {
  const double r = 0.1, h = 0.01, speed = 1.0, gap = 1e-3;
  ModelBuilder mb("pushed pair");
  addFreeBody(mb, "a", solidSphereInertia(1.0, r));
  addFreeBody(mb, "b", solidSphereInertia(1.0, r));
  Pose wall_pose;  // the half-space's normal (local z) along +x, its face at x = 0
  wall_pose.rotation = Eigen::AngleAxisd(0.5 * M_PI, Vector3::UnitY()).toRotationMatrix();
  mb.addDrivenBody(
      DrivenBody::constantTwist("wall", wall_pose, Vector3(speed, 0, 0), Vector3::Zero()));
  mb.setGravity(Vector3::Zero());
  const Model model = mb.build();
  for (MarginRule rule : {MarginRule::Relative, MarginRule::Absolute}) {
    ContactModelBuilder cb(model);
    cb.materials().setDefaultLaw({0.0, 0.0});
    cb.addGeometry("a", BodyRef::dynamic(0), Pose::identity(), Shape::sphere(r));
    cb.addGeometry("b", BodyRef::dynamic(1), Pose::identity(), Shape::sphere(r));
    cb.addGeometry("wall", BodyRef::driven(0), Pose::identity(), Shape::halfSpace());
    ContactModel cmodel = cb.build();
    cmodel.settings.margin_rule = rule;
    SchemeSettings s = settings(h);
    s.normal_law = NormalLaw::Iqs;
    TimeStepper stepper(model, cmodel, s);
    VectorX q = model.neutralConfiguration();
    // A's midpoint position touches the wall's midpoint face (x = speed h / 2)
    const double a0 = r + 0.5 * h * speed;
    q[0] = a0;
    q[model.bodies[1].q_index] = a0 + 2.0 * r + gap;
    stepper.reset(0.0, q, VectorX::Zero(12));
    const StepStats& st = stepper.step();
    const double a = stepper.q()[0], b = stepper.q()[model.bodies[1].q_index];
    SCOPED_TRACE(enumName(rule));
    EXPECT_EQ(st.redetections, rule == MarginRule::Relative ? 1 : 0);
    EXPECT_FALSE(st.margin_outrun);
    if (rule == MarginRule::Relative) {
      EXPECT_GT(st.margin_balls, 0.5 * h * speed);
    }
    EXPECT_GE(b - a - 2.0 * r, -1e-12);          // A pushed on, not into B
    EXPECT_GT(a, a0 + 0.5 * h * speed - 1e-12);  // and A did move with the wall
  }
}

// scheme.compact_sphere_rows: the stepper hands the option to its problem, and the rows it
// writes (sphere on sphere, sphere on a moving driven wall, with friction and rolling
// resistance) move the balls as the body-form rows do, to round-off. The wall pushes A into
// B, which rolls and slides on the plate under it. Unset, the option means compact rows in both
// schemes, bit for bit.
TEST_P(BothSchemes, CompactSphereRowsMoveTheBallsAsTheBodyFormRows) {
  const double r = 0.1, h = 1e-3, speed = 0.5;
  ModelBuilder mb("pushed pair on a plate");
  addFreeBody(mb, "a", solidSphereInertia(1.0, r));
  addFreeBody(mb, "b", solidSphereInertia(2.0, 1.5 * r));
  Pose wall_pose;  // the half-space's normal (local z) along +x, its face at x = 0
  wall_pose.rotation = Eigen::AngleAxisd(0.5 * M_PI, Vector3::UnitY()).toRotationMatrix();
  // a wall moving along x, and up a little: its friction turns A
  mb.addDrivenBody(DrivenBody::constantTwist("wall", wall_pose, Vector3(speed, 0, 0.2 * speed),
                                             Vector3::Zero()));
  const Model model = mb.build();
  std::vector<VectorX> end;
  for (const std::optional<bool> option :
       {std::optional<bool>(false), std::optional<bool>(true), std::optional<bool>()}) {
    ContactModelBuilder cb(model);
    ContactLaw law;
    law.friction = 0.4;
    law.rolling = 0.1;
    cb.materials().setDefaultLaw(law);
    cb.addGeometry("a", BodyRef::dynamic(0), Pose::identity(), Shape::sphere(r));
    cb.addGeometry("b", BodyRef::dynamic(1), Pose::identity(), Shape::sphere(1.5 * r));
    cb.addGeometry("wall", BodyRef::driven(0), Pose::identity(), Shape::halfSpace());
    cb.addGeometry("plate", BodyRef::world(), Pose::identity(), Shape::halfSpace());
    const ContactModel cmodel = cb.build();
    ASSERT_TRUE(cmodel.rolling);
    SchemeSettings s = settings(h);
    s.compact_sphere_rows = option;
    const bool compact = option.value_or(true);
    EXPECT_EQ(s.compactSphereRows(), compact);
    TimeStepper stepper(model, cmodel, s);
    VectorX q = model.neutralConfiguration();
    q[0] = r + 1e-4;  // A against the wall, both on the plate (z up)
    q[2] = r;
    q[model.bodies[1].q_index] = 2.0 * r + 1.5 * r + 2e-4;
    q[model.bodies[1].q_index + 2] = 1.5 * r;
    stepper.reset(0.0, q, VectorX::Zero(12));
    int compact_rows = 0;
    for (int k = 0; k < 100; ++k) {
      stepper.step();
      compact_rows += static_cast<int>(stepper.problem().spheres3d.size());
    }
    EXPECT_EQ(compact_rows > 0, compact);
    end.push_back(stepper.q());
  }
  // both balls went with the wall, and turned
  const int b = model.bodies[1].q_index;
  EXPECT_GT(end[0][0], r + 0.5 * 100 * h * speed);
  EXPECT_GT(end[0][b], end[0][0]);
  const VectorX neutral = model.neutralConfiguration();
  EXPECT_GT((end[0].segment<4>(3) - neutral.segment<4>(3)).norm(), 1e-3);
  EXPECT_LT((end[1] - end[0]).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(end[2], end[1]);
}

// With every mu = 0 the friction stage is skipped, and B's frictionless stage solves the
// same problem as A.
TEST(SchemesAgree, FrictionlessPileSkipsTheFrictionStage) {
  GranularBoxParameters parameters;
  parameters.count = 60;
  parameters.friction = 0.0;
  const Scene scene = granularBox(parameters);
  ASSERT_TRUE(scene.cmodel.frictionless);
  std::vector<VectorX> end;
  for (Scheme scheme : {Scheme::MoreauJean, Scheme::CatchingUp}) {
    SchemeSettings s;
    s.scheme = scheme;
    s.h = 2e-4;
    s.coulomb.tolerance = s.normal_stage.tolerance = 1e-13;
    s.coulomb.max_iterations = s.normal_stage.max_iterations = 100000;
    TimeStepper stepper(scene.model, scene.cmodel, s);
    stepper.reset(0.0, scene.q0, scene.v0);
    for (int k = 0; k < 200; ++k) {
      const StepStats& st = stepper.step();
      EXPECT_EQ(st.iterations_stage2, 0);
    }
    end.push_back(stepper.v());
  }
  EXPECT_LT((end[0] - end[1]).norm(), 1e-8 * end[0].norm());
}

// U_N at v of each of a step's contacts, from a Jacobian with every row built: the stepper's
// own leaves rows out under screening. data: the kinematics at the step's midpoint.
std::vector<double> normalVelocities(const Scene& scene, const Data& data,
                                     const std::vector<Contact>& contacts, const VectorX& v) {
  ContactData all(scene.model, scene.cmodel);
  all.contacts = contacts;
  assembleContactJacobian(scene.model, data, scene.cmodel, all, 0.0);
  std::vector<double> u(contacts.size());
  for (std::size_t c = 0; c < contacts.size(); ++c)
    u[c] = all.jacobian.relativeVelocity(static_cast<int>(c), v).x();
  return u;
}

// Candidate screening solves without the open candidates that are not predicted to close, then
// admits those that break their law. Its answer solves the whole candidate problem: on a
// frictionless pile (unique velocities) each step matches the unscreened one from the same
// state, and every candidate left out keeps its law at the end of the step.
TEST_P(BothSchemes, CandidateScreeningSolvesTheWholeCandidateProblem) {
  GranularBoxParameters parameters;
  parameters.count = 60;
  parameters.friction = 0.0;
  const Scene scene = granularBox(parameters);
  const double h = 1e-3;  // large steps: many open candidates within the detection margin
  SchemeSettings plain = settings(h);
  plain.normal_law = NormalLaw::Iqs;
  plain.coulomb.max_iterations = plain.normal_stage.max_iterations = 100000;
  SchemeSettings screened = plain;
  screened.screening = true;
  screened.screening_gap = 0.0;  // the default takes every near candidate at once: no rounds
  TimeStepper reference(scene.model, scene.cmodel, plain);
  reference.reset(0.0, scene.q0, scene.v0);
  TimeStepper stepper(scene.model, scene.cmodel, screened);
  int deferring_steps = 0, resolved_steps = 0, rowless_steps = 0;
  Data data(scene.model);
  VectorX q_m(scene.model.nq);
  for (int k = 0; k < 120; ++k) {
    stepper.reset(reference.time(), reference.q(), reference.v());
    // the kinematics at the step's midpoint, where its contacts are detected
    integrate(scene.model, reference.q(), 0.5 * h * reference.v(), q_m);
    forwardKinematics(scene.model, data, q_m, reference.v());
    const StepStats& r = reference.step();
    const StepStats& s = stepper.step();
    ASSERT_EQ(s.candidates, r.candidates);
    ASSERT_EQ(s.redetections, r.redetections);
    ASSERT_EQ(r.solves, 1 + r.redetections);  // one solve per detection without screening
    EXPECT_LE(s.active + s.deferred, s.candidates);
    deferring_steps += s.deferred > 0 ? 1 : 0;
    resolved_steps += s.solves > 1 ? 1 : 0;
    rowless_steps += s.unassembled > 0 ? 1 : 0;
    EXPECT_LE((stepper.v() - reference.v()).norm(), 1e-7 * (1.0 + reference.v().norm()))
        << "step " << k;
    // every candidate, with Jacobian rows or not: U_N(k+1) + [g]_+ / tau >= 0 (e = 0), up to
    // the screening slack; U_N from the contact's own Jacobian columns
    const ContactData& cdata = stepper.contactData();
    const double tau = 0.5 * h, slack = touchingGap(scene.cmodel);
    const std::vector<double> u = normalVelocities(scene, data, cdata.contacts, stepper.v());
    for (std::size_t c = 0; c < cdata.contacts.size(); ++c)
      EXPECT_GE(tau * u[c] + std::max(cdata.contacts[c].gap, 0.0), -slack - 1e-12) << "step " << k;
  }
  // the test means something only if screening left candidates out, some without rows, and
  // had to re-solve
  EXPECT_GT(deferring_steps, 60);
  EXPECT_GT(rowless_steps, 60);
  EXPECT_GT(resolved_steps, 0);
}

// With friction and restitution the spheres spin, and the candidates left out without rows are
// judged from their bodies' world twists: every candidate still keeps its law at the end of
// every step, U_N(k+1) + e U_N(k) + [g]_+ / tau >= 0.
TEST(CandidateScreening, EveryCandidateKeepsItsLawAmongSpinningSpheres) {
  GranularBoxParameters parameters;
  parameters.count = 60;
  parameters.planar = false;
  parameters.friction = 0.5;
  parameters.restitution = 0.5;
  const Scene scene = granularBox(parameters);
  SchemeSettings s;
  s.h = 1e-3;
  s.normal_law = NormalLaw::Iqs;
  s.coulomb.tolerance = 1e-12;
  s.coulomb.max_iterations = 100000;
  s.screening = true;
  s.screening_gap = 0.0;
  TimeStepper stepper(scene.model, scene.cmodel, s);
  // thrown in every direction, spinning: collisions at all angles from the first steps
  VectorX v0(scene.model.nv);
  for (int i = 0; i < scene.model.nv; ++i) v0[i] = 0.3 * std::sin(1.7 * i + 0.4);
  stepper.reset(0.0, scene.q0, v0);
  Data data(scene.model);
  VectorX q_m(scene.model.nq);
  const double tau = 0.5 * s.h;
  int rowless_steps = 0, resolved_steps = 0;
  double spin = 0.0;
  for (int k = 0; k < 200; ++k) {
    const VectorX v_start = stepper.v();
    integrate(scene.model, stepper.q(), tau * v_start, q_m);
    forwardKinematics(scene.model, data, q_m, v_start);
    const StepStats& st = stepper.step();
    rowless_steps += st.unassembled > 0 ? 1 : 0;
    resolved_steps += st.solves > 1 ? 1 : 0;
    for (std::size_t b = 0; b < scene.model.bodies.size(); ++b)
      spin = std::max(spin, data.velocity[b].head<3>().norm());
    const std::vector<Contact>& contacts = stepper.contactData().contacts;
    const std::vector<double> u_start = normalVelocities(scene, data, contacts, v_start);
    const std::vector<double> u_end = normalVelocities(scene, data, contacts, stepper.v());
    for (std::size_t c = 0; c < contacts.size(); ++c)
      EXPECT_GE(
          tau * (u_end[c] + contacts[c].restitution * u_start[c]) + std::max(contacts[c].gap, 0.0),
          -1e-9 * parameters.radius)
          << "step " << k;
  }
  EXPECT_GT(spin, 1.0);  // rad/s: the body frames turn, the twists must be rotated to world
  EXPECT_GT(rowless_steps, 100);
  EXPECT_GT(resolved_steps, 0);
}

// After screening_rounds solves every candidate joins: nothing is left out of the last one.
TEST(CandidateScreening, EveryCandidateJoinsAfterTheLastRound) {
  GranularBoxParameters parameters;
  parameters.count = 60;
  const Scene scene = granularBox(parameters);
  SchemeSettings s;
  s.h = 1e-3;
  s.normal_law = NormalLaw::Iqs;
  s.screening = true;
  s.screening_rounds = 1;
  s.screening_gap = 0.0;
  TimeStepper stepper(scene.model, scene.cmodel, s);
  stepper.reset(0.0, scene.q0, scene.v0);
  int capped = 0;
  for (int k = 0; k < 120; ++k) {
    const StepStats& st = stepper.step();
    EXPECT_LE(st.solves, 2);
    if (st.solves == 2) {
      EXPECT_EQ(st.deferred, 0);
      EXPECT_EQ(st.active, st.candidates);
      ++capped;
    }
  }
  EXPECT_GT(capped, 0);
}

// Random contact order is seeded: the same run twice gives the same bits.
TEST(Determinism, ShuffledSweepsRepeat) {
  GranularBoxParameters parameters;
  parameters.count = 60;
  const Scene scene = granularBox(parameters);
  for (Scheme scheme : {Scheme::MoreauJean, Scheme::CatchingUp}) {
    std::vector<VectorX> end;
    for (int run = 0; run < 2; ++run) {
      SchemeSettings s;
      s.scheme = scheme;
      s.h = 2e-4;
      s.coulomb.shuffle = s.normal_stage.shuffle = s.friction_stage.shuffle = true;
      TimeStepper stepper(scene.model, scene.cmodel, s);
      stepper.reset(0.0, scene.q0, scene.v0);
      for (int k = 0; k < 200; ++k) stepper.step();
      end.push_back(stepper.q());
    }
    EXPECT_EQ(end[0], end[1]) << enumName(scheme);
  }
}

INSTANTIATE_TEST_SUITE_P(Schemes, BothSchemes,
                         ::testing::Values(Scheme::MoreauJean, Scheme::CatchingUp),
                         test::schemeTestName);

}  // namespace
}  // namespace sweep
