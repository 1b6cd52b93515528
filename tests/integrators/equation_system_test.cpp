// Systems by their equations and constraints by functions (framework/model.hpp): the same
// index sets and solves as bodies and contacts, for both schemes.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "contact/contact_model.hpp"
#include "framework/error.hpp"
#include "framework/urdf_import.hpp"
#include "integrators/time_stepper.hpp"
#include "models/rigid_bodies.hpp"

namespace sweep {
namespace {

constexpr double kG = 9.81;

SchemeSettings settingsFor(Scheme scheme, double h) {
  SchemeSettings s;
  s.scheme = scheme;
  s.h = h;
  s.coulomb.tolerance = s.normal_stage.tolerance = s.friction_stage.tolerance = 1e-12;
  return s;
}

ContactModel planar() {
  ContactModel cmodel;
  cmodel.dimension = 2;
  return cmodel;
}

// A model of one system by its equations and its constraints by functions.
Model systemModel(const std::string& name, const EquationSystem& system,
                  const std::vector<ConstraintFunction>& constraints) {
  ModelBuilder builder(name);
  builder.addSystem(system);
  for (const ConstraintFunction& c : constraints) builder.addConstraint(c);
  return builder.build();
}

// A point mass m in the plane, q = (x, y), under gravity along -y.
EquationSystem pointMass(const std::string& name, double m) {
  EquationSystem point;
  point.name = name;
  point.nq = point.nv = 2;
  point.mass = [m](const VectorX&) { return MatrixX(m * MatrixX::Identity(2, 2)); };
  point.constant_mass = true;
  point.forces = [m](double, const VectorX&, const VectorX&) {
    return VectorX(Eigen::Vector2d(0.0, -m * kG));
  };
  point.potential = [m](const VectorX& q) { return m * kG * q[1]; };
  return point;
}

// The point mass on the floor y >= 0 with friction mu and restitution e.
Model pointMassOnFloor(double m, double mu, double e) {
  const EquationSystem mass = pointMass("point", m);
  ConstraintFunction floor;
  floor.name = "floor";
  floor.gap = [](const VectorX& q) { return q[1]; };
  floor.normal = [](const VectorX&) { return VectorX(Eigen::Vector2d(0.0, 1.0)); };
  floor.tangent = [](const VectorX&) { return VectorX(Eigen::Vector2d(1.0, 0.0)); };
  floor.friction = mu;
  floor.restitution = e;
  return systemModel("point mass", mass, {floor});
}

class EquationSystems : public ::testing::TestWithParam<Scheme> {};

// V8, the Kane impact, as a runnable system: M = I on R^2, the constraint q_0 >= 0 with
// W_N = (1, 0), W_T = (0.9, sqrt(0.19)), mu = 0.5, e = 1, hit at U_N = U_T = -1. Jean-Moreau
// gains energy (+0.4959, v+ = (1, -1.02195)); the staggered scheme does not (v+ = (1, 0)):
// the numbers of the solver-level test KaneImpact.*, here through the whole time step.
TEST_P(EquationSystems, KaneImpactThroughTheTimeStep) {
  EquationSystem kane;
  kane.name = "kane";
  kane.nq = kane.nv = 2;
  kane.mass = [](const VectorX&) { return MatrixX(MatrixX::Identity(2, 2)); };
  ConstraintFunction wall;
  wall.name = "wall";
  wall.gap = [](const VectorX& q) { return q[0]; };
  wall.normal = [](const VectorX&) { return VectorX(Eigen::Vector2d(1.0, 0.0)); };
  wall.tangent = [](const VectorX&) { return VectorX(Eigen::Vector2d(0.9, std::sqrt(0.19))); };
  wall.friction = 0.5;
  wall.restitution = 1.0;
  const Model model = systemModel("kane", kane, {wall});
  const ContactModel cmodel = planar();
  TimeStepper stepper(model, cmodel, settingsFor(GetParam(), 1e-3));
  const VectorX v_minus = Eigen::Vector2d(-1.0, -0.1 / std::sqrt(0.19));
  stepper.reset(0.0, Eigen::Vector2d(0.0, 0.0), v_minus);
  const StepStats& s = stepper.step();
  EXPECT_EQ(s.active, 1);
  const VectorX& v = stepper.v();
  const double dKE = 0.5 * v.squaredNorm() - 0.5 * v_minus.squaredNorm();
  if (GetParam() == Scheme::MoreauJean) {
    EXPECT_NEAR(v[0], 1.0, 1e-4);
    EXPECT_NEAR(v[1], -1.02195, 1e-4);
    EXPECT_NEAR(dKE, 0.4959, 1e-3);
    EXPECT_NEAR(stepper.constraintImpulses()[0].x(), 3.6364, 1e-4);
  } else {
    EXPECT_NEAR(v[0], 1.0, 1e-6);
    EXPECT_NEAR(v[1], 0.0, 1e-6);
    EXPECT_LT(dKE, 0.0);
  }
}

// A point mass dropped on the floor with e = 0.5 rebounds at -e times its impact velocity
// (Newton's law, VEL), loses energy, then rests: the constraint then carries m g h per step
// and the mass stays within VEL's penetration, h times the impact speed.
TEST_P(EquationSystems, PointMassBouncesThenRests) {
  const double m = 2.0, h = 1e-3, e = 0.5;
  const Model model = pointMassOnFloor(m, 0.3, e);
  const ContactModel cmodel = planar();
  TimeStepper stepper(model, cmodel, settingsFor(GetParam(), h));
  stepper.reset(0.0, Eigen::Vector2d(0.0, 0.2), Eigen::Vector2d(0.0, 0.0));
  const double energy0 = stepper.energy();
  double lowest = 1.0, impact = 0.0, rebound = 0.0;
  for (int k = 0; k < 3000; ++k) {
    const double before = stepper.v()[1];
    const StepStats& s = stepper.step();
    ASSERT_NE(s.status, SolverStatus::Failed);
    if (impact == 0.0 && stepper.v()[1] > 0.0) {
      impact = before;
      rebound = stepper.v()[1];
    }
    lowest = std::min(lowest, stepper.q()[1]);
  }
  ASSERT_LT(impact, -1.9);                  // sqrt(2 g 0.2) = 1.98 m/s
  EXPECT_NEAR(rebound, -e * impact, 1e-9);  // U_N(k+1) = -e U_N(k)
  EXPECT_GT(lowest, h * impact);
  EXPECT_LE(stepper.q()[1], 0.0);
  EXPECT_NEAR(stepper.v()[1], 0.0, 1e-9);
  EXPECT_NEAR(stepper.constraintImpulses()[0].x(), m * kG * h, 1e-9);
  EXPECT_LT(stepper.energy(), 0.1 * energy0);
}

// Friction through the constraint's tangent: the mass pushed along the floor at 1 m/s slows at
// mu g and stops (mu = 0.4: after 1 / (mu g) s, at 1 / (2 mu g) m).
TEST_P(EquationSystems, PointMassSlidesToRestWithCoulombFriction) {
  const double mu = 0.4, h = 1e-4;
  const Model model = pointMassOnFloor(1.0, mu, 0.0);
  const ContactModel cmodel = planar();
  TimeStepper stepper(model, cmodel, settingsFor(GetParam(), h));
  stepper.reset(0.0, Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(1.0, 0.0));
  const int half = static_cast<int>(std::round(0.5 / (mu * kG) / h));
  for (int k = 0; k < half; ++k) stepper.step();
  EXPECT_NEAR(stepper.v()[0], 0.5, 1e-3);
  for (int k = 0; k < 2 * half; ++k) stepper.step();
  EXPECT_NEAR(stepper.v()[0], 0.0, 1e-12);
  EXPECT_NEAR(stepper.q()[0], 1.0 / (2.0 * mu * kG), 1e-3);
}

// A system beside a body tree: the body moves as it does alone (M is block diagonal and
// nothing couples them), to the bit, while the system falls on its own.
TEST_P(EquationSystems, MixWithBodiesWithoutChangingThem) {
  auto pendulum = [](ModelBuilder& builder) {
    builder.setGravity(Vector3(0, -kG, 0));
    builder.addBody(-1, "hinge", Joint::revolute(Vector3::UnitZ()), Pose::identity(),
                    Inertia{1.0, Vector3(0.5, 0.0, 0.0), Matrix3::Identity() * 1e-3}, "bob");
  };
  ModelBuilder alone_builder("pendulum");
  pendulum(alone_builder);
  const Model alone = alone_builder.build();
  ModelBuilder mixed_builder("pendulum and point");
  pendulum(mixed_builder);
  EquationSystem point;
  point.name = "point";
  point.nq = point.nv = 1;
  point.mass = [](const VectorX&) { return MatrixX(MatrixX::Constant(1, 1, 3.0)); };
  point.forces = [](double, const VectorX&, const VectorX&) {
    return VectorX(VectorX::Constant(1, -3.0 * kG));
  };
  mixed_builder.addSystem(point);
  const Model mixed = mixed_builder.build();
  ASSERT_EQ(mixed.nq, 2);
  EXPECT_EQ(mixed.dofNames().back(), "point:0");
  const ContactModel cmodel = planar();
  TimeStepper a(alone, cmodel, settingsFor(GetParam(), 1e-3));
  TimeStepper b(mixed, cmodel, settingsFor(GetParam(), 1e-3));
  a.reset(0.0, VectorX::Constant(1, 0.3), VectorX::Zero(1));
  b.reset(0.0, Eigen::Vector2d(0.3, 5.0), VectorX::Zero(2));
  for (int k = 0; k < 500; ++k) {
    a.step();
    b.step();
  }
  EXPECT_EQ(a.q()[0], b.q()[0]);
  EXPECT_EQ(a.v()[0], b.v()[0]);
  EXPECT_NEAR(b.v()[1], -kG * 0.5, 1e-12);
}

// A pendulum as a point mass on a rod: the bilateral constraint |q| - L = 0, whose impulse
// (the rod's tension) points inwards, against its normal. The mass stays on the circle, swings
// with the small-angle period 2 pi sqrt(L / g), and the energy does not grow.
TEST_P(EquationSystems, BilateralRodMakesAPendulum) {
  const double m = 1.5, L = 0.5, h = 1e-3, angle = 0.1;
  const EquationSystem point = pointMass("bob", m);
  ConstraintFunction rod;
  rod.name = "rod";
  rod.bilateral = true;
  rod.gap = [L](const VectorX& q) { return q.norm() - L; };
  rod.normal = [](const VectorX& q) { return VectorX(q / q.norm()); };
  const Model model = systemModel("pendulum by its equations", point, {rod});
  const ContactModel cmodel = planar();
  TimeStepper stepper(model, cmodel, settingsFor(GetParam(), h));
  stepper.reset(0.0, Eigen::Vector2d(L * std::sin(angle), -L * std::cos(angle)), VectorX::Zero(2));
  const double energy0 = stepper.energy();
  double worst_length = 0.0, highest_energy = energy0, previous_x = stepper.q()[0];
  std::vector<double> crossings;
  for (int k = 0; k < 3000; ++k) {
    const StepStats& s = stepper.step();
    ASSERT_EQ(s.active, 1);
    EXPECT_LT(stepper.constraintImpulses()[0].x(), 0.0);  // tension
    worst_length = std::max(worst_length, std::abs(stepper.q().norm() - L));
    highest_energy = std::max(highest_energy, stepper.energy());
    const double x = stepper.q()[0];
    if ((previous_x > 0.0) != (x > 0.0))  // linear interpolation of the crossing time
      crossings.push_back(stepper.time() - h * x / (x - previous_x));
    previous_x = x;
  }
  EXPECT_LT(worst_length, 1e-3 * L);
  EXPECT_LT(highest_energy - energy0, 1e-6 * std::abs(energy0));
  ASSERT_GE(crossings.size(), 4u);
  const double period =
      2.0 * (crossings.back() - crossings.front()) / static_cast<double>(crossings.size() - 1);
  // small-angle period, raised by (1 + angle^2 / 16) at this amplitude
  const double expected = 2.0 * M_PI * std::sqrt(L / kG) * (1.0 + angle * angle / 16.0);
  EXPECT_NEAR(period, expected, 2e-3 * expected);
}

// A URDF <mimic> joint (tests/data/urdf/gripper_mimic.urdf): the right finger follows the left,
// q_r = 2 q_l + 0.01. Gravity along -x pulls the left finger closed and the right one open; held
// together, the left opens at a = -g (m_l - 2 m_r) / (m_l + 4 m_r) = +1.962 m/s^2. The constraint
// is linear and solved at the velocity level, so the midpoint update keeps it to round-off.
TEST_P(EquationSystems, UrdfMimicJointHoldsItsRatio) {
  ModelBuilder builder("gripper");
  addUrdf(builder, std::string(SWEEP_TEST_DATA) + "/urdf/gripper_mimic.urdf");
  builder.setGravity(Vector3(-kG, 0.0, 0.0));
  const Model model = builder.build();
  ASSERT_EQ(model.constraints.size(), 1u);
  const int left = model.dofIndex("finger_left"), right = model.dofIndex("finger_right");
  const ContactModel cmodel;
  const double h = 1e-3, a = -kG * (0.1 - 2.0 * 0.1) / (0.1 + 4.0 * 0.1);
  TimeStepper stepper(model, cmodel, settingsFor(GetParam(), h));
  VectorX q0 = VectorX::Zero(model.nq);
  q0[left] = 0.01;
  q0[right] = 2.0 * 0.01 + 0.01;
  stepper.reset(0.0, q0, VectorX::Zero(model.nv));
  double worst_ratio = 0.0;
  for (int k = 0; k < 100; ++k) {
    ASSERT_EQ(stepper.step().active, 1);
    worst_ratio =
        std::max(worst_ratio, std::abs(stepper.q()[right] - 2.0 * stepper.q()[left] - 0.01));
  }
  EXPECT_LT(worst_ratio, 1e-12);
  const double t = stepper.time();
  EXPECT_NEAR(stepper.q()[left], 0.01 + 0.5 * a * t * t, 1e-9);
  EXPECT_NEAR(stepper.v()[left], a * t, 1e-9);
}

// limits_as_written.urdf with gravity swinging each pendulum towards negative angles: the locked
// one stays at 0.2 rad, the one bounded below stops at -0.1 rad, the unbounded one swings on.
TEST_P(EquationSystems, ALockedJointStaysWhereItsEqualBoundsHoldIt) {
  ModelBuilder builder("limits");
  addUrdf(builder, std::string(SWEEP_TEST_DATA) + "/urdf/limits_as_written.urdf");
  builder.setGravity(Vector3(kG, 0.0, 0.0));  // pulls each bob towards negative angles
  const Model model = builder.build();
  const int locked = model.dofIndex("locked"), lower_only = model.dofIndex("lower_only"),
            unbounded = model.dofIndex("unbounded");
  const ContactModel cmodel;
  TimeStepper stepper(model, cmodel, settingsFor(GetParam(), 1e-3));
  VectorX q0 = VectorX::Zero(model.nq);
  q0[locked] = 0.2;
  stepper.reset(0.0, q0, VectorX::Zero(model.nv));
  double locked_off = 0.0, lower_least = 0.0, unbounded_least = 0.0;
  for (int k = 0; k < 400; ++k) {
    stepper.step();
    locked_off = std::max(locked_off, std::abs(stepper.q()[locked] - 0.2));
    lower_least = std::min(lower_least, stepper.q()[lower_only]);
    unbounded_least = std::min(unbounded_least, stepper.q()[unbounded]);
  }
  EXPECT_LT(locked_off, 1e-6);
  // an impact at the velocity level passes a bound by about h v / 2 (here 1e-3 rad)
  EXPECT_GT(lower_least, -0.1 - 2e-3);
  EXPECT_LT(unbounded_least, -0.5);
}

// A double pendulum (point masses 1 at the ends of unit links, 0.01 about each centre, the
// elbow limited to +-0.1 rad) built from bodies, against the same written by its equations:
// M(q), Coriolis and gravity in relative angles, the limits as two constraints by functions.
// Released at 1 rad, the elbow hits its limits; the two runs agree to round-off.
TEST_P(EquationSystems, DoublePendulumByItsEquationsMatchesTheTree) {
  const double m = 1.0, I = 0.01, limit = 0.1, h = 1e-3;
  ModelBuilder trees("double pendulum");
  const Inertia link{m, Vector3(0, -1, 0), I * Matrix3::Identity()};
  const int upper =
      trees.addBody(-1, "shoulder", Joint::revolute(Vector3::UnitZ()), Pose{}, link, "upper");
  Pose elbow_placement;
  elbow_placement.translation = Vector3(0, -1, 0);
  const int lower = trees.addBody(upper, "elbow", Joint::revolute(Vector3::UnitZ()),
                                  elbow_placement, link, "lower");
  trees.addJointLimits(lower, -limit, limit);
  trees.setGravity(Vector3(0, -kG, 0));
  const Model tree = trees.build();

  EquationSystem pendulum;
  pendulum.name = "double pendulum";
  pendulum.nq = pendulum.nv = 2;
  pendulum.mass = [=](const VectorX& q) {
    const double c2 = std::cos(q[1]);
    Eigen::Matrix2d M;
    M << 3 * m + 2 * m * c2 + 2 * I, m + m * c2 + I, m + m * c2 + I, m + I;
    return MatrixX(M);
  };
  pendulum.forces = [=](double, const VectorX& q, const VectorX& v) {
    const double s2 = std::sin(q[1]), s1 = std::sin(q[0]), s12 = std::sin(q[0] + q[1]);
    return VectorX(
        Eigen::Vector2d(m * s2 * (2 * v[0] * v[1] + v[1] * v[1]) - m * kG * (2 * s1 + s12),
                        -m * s2 * v[0] * v[0] - m * kG * s12));
  };
  pendulum.potential = [=](const VectorX& q) {
    return -m * kG * (2 * std::cos(q[0]) + std::cos(q[0] + q[1]));
  };
  std::vector<ConstraintFunction> bounds;
  for (const double side : {1.0, -1.0}) {
    ConstraintFunction bound;
    bound.name = side > 0 ? "elbow lower" : "elbow upper";
    bound.gap = [=](const VectorX& q) { return side * (q[1] + side * limit); };
    bound.normal = [=](const VectorX&) { return VectorX(Eigen::Vector2d(0.0, side)); };
    bounds.push_back(bound);
  }
  const Model system = systemModel("double pendulum by its equations", pendulum, bounds);

  const ContactModel cmodel = planar();
  TimeStepper from_tree(tree, cmodel, settingsFor(GetParam(), h));
  TimeStepper from_equations(system, cmodel, settingsFor(GetParam(), h));
  const VectorX q0 = Eigen::Vector2d(1.0, 0.0);
  from_tree.reset(0.0, q0, VectorX::Zero(2));
  from_equations.reset(0.0, q0, VectorX::Zero(2));
  int impacts = 0;
  double worst = 0.0;
  for (int k = 0; k < 1000; ++k) {
    const int active = from_tree.step().active;
    ASSERT_EQ(from_equations.step().active, active) << "step " << k;
    impacts += active;
    worst = std::max({worst, (from_tree.q() - from_equations.q()).lpNorm<Eigen::Infinity>(),
                      h * (from_tree.v() - from_equations.v()).lpNorm<Eigen::Infinity>()});
  }
  EXPECT_GT(impacts, 0);
  EXPECT_LT(worst, 1e-10);
  EXPECT_NEAR(from_tree.energy(), from_equations.energy(), 1e-10);
}

// V4, the disk on an incline (tan a = 0.6, mu = 0.25: it rolls), as a body on a half-plane and
// as q = (x, y, theta) with M = diag(m, m, I) and the contact written as a constraint by
// functions: gap n . p - R, normal (n, 0), tangent (t, r_c x t) with r_c = -R n the contact
// point from the centre. Both roll at 2/3 g sin a and agree to round-off.
TEST_P(EquationSystems, DiskOnInclineByItsEquationsMatchesTheBody) {
  const double m = 1.0, R = 0.1, I = 0.5 * m * R * R, mu = 0.25, h = 1e-3;
  const double angle = std::atan(0.6);
  const Eigen::Vector2d n(-std::sin(angle), std::cos(angle)), t(n.y(), -n.x());
  ModelBuilder bodies("disk on incline");
  addPlanarBody(bodies, "disk", solidDiskInertia(m, R));
  bodies.setGravity(Vector3(0, -kG, 0));
  const Model body = bodies.build();
  ContactModelBuilder cb(body);
  cb.materials().setDefaultLaw({mu, 0.0});
  cb.addGeometry("disk", BodyRef::dynamic(0), Pose::identity(), Shape::disk(R));
  Pose slope;
  slope.rotation = Eigen::AngleAxisd(angle, Vector3::UnitZ()).toRotationMatrix();
  cb.addGeometry("slope", BodyRef::world(), slope, Shape::halfPlane());
  const ContactModel cmodel = cb.build();

  EquationSystem disk;
  disk.name = "disk";
  disk.nq = disk.nv = 3;
  disk.mass = [=](const VectorX&) { return MatrixX(Eigen::Vector3d(m, m, I).asDiagonal()); };
  disk.constant_mass = true;
  disk.forces = [=](double, const VectorX&, const VectorX&) {
    return VectorX(Eigen::Vector3d(0.0, -m * kG, 0.0));
  };
  disk.potential = [=](const VectorX& q) { return m * kG * q[1]; };
  ConstraintFunction contact;
  contact.name = "slope";
  contact.gap = [=](const VectorX& q) { return n.dot(q.head<2>()) - R; };
  contact.normal = [=](const VectorX&) { return VectorX(Eigen::Vector3d(n.x(), n.y(), 0.0)); };
  const Eigen::Vector2d r_c = -R * n;
  contact.tangent = [=](const VectorX&) {
    return VectorX(Eigen::Vector3d(t.x(), t.y(), r_c.x() * t.y() - r_c.y() * t.x()));
  };
  contact.friction = mu;
  const Model system = systemModel("disk by its equations", disk, {contact});
  const ContactModel none = planar();

  TimeStepper from_body(body, cmodel, settingsFor(GetParam(), h));
  TimeStepper from_equations(system, none, settingsFor(GetParam(), h));
  const VectorX q0 = Eigen::Vector3d(R * n.x(), R * n.y(), 0.0);
  from_body.reset(0.0, q0, VectorX::Zero(3));
  from_equations.reset(0.0, q0, VectorX::Zero(3));
  double worst = 0.0;
  for (int k = 0; k < 500; ++k) {
    ASSERT_EQ(from_body.step().active, 1);
    ASSERT_EQ(from_equations.step().active, 1);
    worst = std::max(worst, (from_body.q() - from_equations.q()).lpNorm<Eigen::Infinity>());
  }
  EXPECT_LT(worst, 1e-12);
  const double speed = -t.dot(from_equations.v().head<2>());  // t points up the slope
  EXPECT_NEAR(speed, 2.0 / 3.0 * kG * std::sin(angle) * from_equations.time(), 1e-9);
  EXPECT_NEAR(from_equations.v()[2] * R, speed, 1e-9);  // rolling: omega R = speed
}

INSTANTIATE_TEST_SUITE_P(BothSchemes, EquationSystems,
                         ::testing::Values(Scheme::MoreauJean, Scheme::CatchingUp),
                         [](const auto& param_info) {
                           return param_info.param == Scheme::MoreauJean ? "MoreauJean"
                                                                         : "CatchingUp";
                         });

TEST(EquationSystemErrors, DefinitionsAreChecked) {
  ModelBuilder builder("bad");
  EquationSystem s;
  s.name = "s";
  s.nq = 2;
  s.nv = 1;
  s.mass = [](const VectorX&) { return MatrixX(MatrixX::Identity(1, 1)); };
  try {
    builder.addSystem(s);
    FAIL() << "nq != nv without integrate";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("system 's': nq = 2 differs from nv = 1"),
              std::string::npos)
        << e.what();
  }
  s.nq = 1;
  s.mass = nullptr;
  EXPECT_THROW(builder.addSystem(s), InputError);
  ConstraintFunction c;
  c.name = "c";
  c.gap = [](const VectorX& q) { return q[0]; };
  EXPECT_THROW(builder.addConstraint(c), InputError);  // no normal
  c.normal = [](const VectorX&) { return VectorX(VectorX::Ones(1)); };
  c.friction = 0.5;
  EXPECT_THROW(builder.addConstraint(c), InputError);  // friction without a tangent
  c.tangent = [](const VectorX&) { return VectorX(VectorX::Ones(1)); };
  c.bilateral = true;
  EXPECT_THROW(builder.addConstraint(c), InputError);  // a bilateral one with friction

  // a singular mass matrix at the reference configuration
  ModelBuilder singular("singular");
  s.mass = [](const VectorX&) { return MatrixX(MatrixX::Zero(1, 1)); };
  singular.addSystem(s);
  EXPECT_THROW(singular.build(), InputError);

  // a mass function of the wrong size is caught when it is called, naming the system
  ModelBuilder sized("sized");
  s.mass = [](const VectorX& q) {
    return q[0] > 0.5 ? MatrixX(MatrixX::Identity(2, 2)) : MatrixX(MatrixX::Identity(1, 1));
  };
  sized.addSystem(s);
  const Model model = sized.build();
  const ContactModel cmodel = planar();  // the stepper keeps a reference
  TimeStepper stepper(model, cmodel, settingsFor(Scheme::MoreauJean, 1e-3));
  stepper.reset(0.0, VectorX::Constant(1, 1.0), VectorX::Zero(1));
  try {
    stepper.step();
    FAIL() << "a 2 x 2 mass matrix for nv = 1";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("system 's': its mass matrix must be a finite 1 x 1"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace sweep
