// Adhesion (ContactLaw: pull-off force F per contact point, P_N >= -h F, thresholds from
// P_N + h F) in both schemes, against answers in closed form.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "framework/enum_names.hpp"
#include "framework/error.hpp"
#include "integrators/time_stepper.hpp"
#include "models/granular.hpp"
#include "models/rigid_bodies.hpp"
#include "solver_fixtures.hpp"

namespace sweep {
namespace {

class Adhesion : public ::testing::TestWithParam<Scheme> {
 protected:
  SchemeSettings settings(double h) const {
    SchemeSettings s;
    s.scheme = GetParam();
    s.h = h;
    s.coulomb.tolerance = s.normal_stage.tolerance = s.friction_stage.tolerance = 1e-12;
    return s;
  }
};

// A ball of mass m and radius r under a ceiling: a floor with gravity pointing away from it
// (+z). The DMT pull-off force 4 pi gamma r holds it where it exceeds m g.
struct BallUnderCeiling {
  Model model;
  ContactModel cmodel;
  BallUnderCeiling(double mass, double radius, double surface_energy, double range = 0.0) {
    ModelBuilder mb("ball under a ceiling");
    addFreeBody(mb, "ball", solidSphereInertia(mass, radius));
    mb.setGravity(Vector3(0, 0, 9.81));
    model = mb.build();
    ContactModelBuilder cb(model);
    ContactLaw law{0.5, 0.0};
    law.surface_energy = surface_energy;
    law.adhesion_range = range;
    cb.materials().setDefaultLaw(law);
    cb.addGeometry("ball", BodyRef::dynamic(0), Pose::identity(), Shape::sphere(radius));
    cb.addGeometry("ceiling", BodyRef::world(), Pose::identity(), Shape::halfSpace());
    cmodel = cb.build();
  }
};

TEST_P(Adhesion, ABallHangsUnderACeilingWhileItsPullOffForceExceedsItsWeight) {
  const double m = 2.0, r = 0.1, g = 9.81, h = 1e-3;
  const double gamma_weight = m * g / (4.0 * M_PI * r);  // pull-off force = weight
  for (const double ratio : {1.05, 0.95}) {
    const BallUnderCeiling scene(m, r, ratio * gamma_weight);
    EXPECT_TRUE(scene.cmodel.adhesive());
    TimeStepper stepper(scene.model, scene.cmodel, settings(h));
    VectorX q = scene.model.neutralConfiguration();
    q[2] = r;
    stepper.reset(0.0, q, VectorX::Zero(6));
    const int steps = 200;
    for (int k = 0; k < steps; ++k) {
      const StepStats& s = stepper.step();
      if (ratio > 1.0) {
        ASSERT_EQ(s.active, 1) << "step " << k;
        // a tension equal to the weight, within the pull-off bound
        EXPECT_NEAR(stepper.impulses()[0].x(), -m * g * h, 1e-9 * m * g * h) << "step " << k;
      }
    }
    const double T = steps * h;
    if (ratio > 1.0) {
      EXPECT_NEAR(stepper.q()[2], r, 1e-12);
      EXPECT_LT(stepper.v().norm(), 1e-9);
    } else {
      // the first step pulls with F and lets go; then the ball falls freely: between
      // (g - F/m) T^2 / 2 and g T^2 / 2 below... away from the ceiling
      const double drop = stepper.q()[2] - r;
      EXPECT_GT(drop, 0.5 * g * (T - h) * (T - h));
      EXPECT_LT(drop, 0.5 * g * T * T);
    }
  }
}

// A ball below the ceiling within adhesion_range is pulled up to it (net acceleration
// F / m - g = g) under every normal law and hangs there (under VEL and IQS at rest, with the
// landing's overlap); one beyond the range falls.
TEST_P(Adhesion, ABallWithinTheRangeIsPulledUpAndOneBeyondItFalls) {
  const double m = 2.0, r = 0.1, g = 9.81, h = 1e-3, range = 1e-3;
  const double gamma = 2.0 * m * g / (4.0 * M_PI * r);  // F = 2 m g
  for (const NormalLaw law : {NormalLaw::Vel, NormalLaw::Iqs, NormalLaw::Pos}) {
    for (const double gap : {0.5 * range, 2.0 * range}) {
      const BallUnderCeiling scene(m, r, gamma, range);
      SchemeSettings s = settings(h);
      s.normal_law = law;
      TimeStepper stepper(scene.model, scene.cmodel, s);
      VectorX q = scene.model.neutralConfiguration();
      q[2] = r + gap;
      stepper.reset(0.0, q, VectorX::Zero(6));
      for (int k = 0; k < 100; ++k) stepper.step();
      const std::string what = std::string(enumName(law)) + ", gap " + std::to_string(gap);
      if (gap < range && law == NormalLaw::Pos) {
        // POS pushes the landing's overlap out as a separation speed; the pull keeps it within
        EXPECT_LT(std::abs(stepper.q()[2] - r), range) << what;
      } else if (gap < range) {
        // VEL and IQS keep the overlap of the landing step, h/2 times the arrival speed
        const double arrival = std::sqrt(2.0 * (2.0 * g - g) * gap);
        EXPECT_LE(r - stepper.q()[2], 0.5 * h * arrival) << what;
        EXPECT_GE(r - stepper.q()[2], 0.0) << what;
        EXPECT_LT(stepper.v().norm(), 1e-9) << what;
        EXPECT_NEAR(stepper.impulses()[0].x(), -m * g * h, 1e-9 * m * g * h) << what;
      } else {
        EXPECT_GT(stepper.q()[2] - r - gap, 0.5 * g * 0.099 * 0.099) << what;
      }
    }
  }
}

// Two free balls touching in zero gravity, pulled apart by equal and opposite loads P along
// their line of centres: they hold together while P < F = 4 pi gamma R* (R* = r / 2) and
// separate with relative acceleration 2 P / m (after the first step) above it.
TEST_P(Adhesion, TwoBallsSeparateAtThePullOffForce) {
  const double m = 0.5, r = 0.05, gamma = 2.0, h = 1e-3;
  const double F = 4.0 * M_PI * gamma * (0.5 * r);
  for (const double ratio : {0.95, 1.05}) {
    ModelBuilder mb("two balls");
    addFreeBody(mb, "a", solidSphereInertia(m, r));
    addFreeBody(mb, "b", solidSphereInertia(m, r));
    mb.setGravity(Vector3::Zero());
    const Model model = mb.build();
    ContactModelBuilder cb(model);
    ContactLaw law{0.3, 0.0};
    law.surface_energy = gamma;
    cb.materials().setDefaultLaw(law);
    cb.addGeometry("a", BodyRef::dynamic(0), Pose::identity(), Shape::sphere(r));
    cb.addGeometry("b", BodyRef::dynamic(1), Pose::identity(), Shape::sphere(r));
    const ContactModel cmodel = cb.build();
    const double P = ratio * F;
    const int va = model.components[0].v_index, vb = model.components[1].v_index;
    auto pull = [&](double, const VectorX&, const VectorX&, VectorX& tau) {
      tau[va] -= P;  // a to -x, b to +x
      tau[vb] += P;
    };
    TimeStepper stepper(model, cmodel, settings(h), pull);
    VectorX q = model.neutralConfiguration();
    q[model.components[0].q_index] = -r;
    q[model.components[1].q_index] = r;
    stepper.reset(0.0, q, VectorX::Zero(model.nv));
    for (int k = 0; k < 100; ++k) stepper.step();
    const double separation =
        stepper.q()[model.components[1].q_index] - stepper.q()[model.components[0].q_index];
    if (ratio < 1.0) {
      EXPECT_NEAR(separation, 2.0 * r, 1e-12);
      EXPECT_NEAR(stepper.impulses()[0].x(), -P * h, 1e-9 * P * h);  // the tension is the load
    } else {
      EXPECT_GT(separation - 2.0 * r, 0.5 * (2.0 * P / m) * 0.098 * 0.098);
    }
  }
}

// A disk (a point mass on two prismatic joints) on an incline of angle a with friction mu
// and a pull-off force F per unit thickness: the normal force is m g cos a + F, so it sticks
// while tan a <= mu (1 + F / (m g cos a)) and slides with g sin a - mu (g cos a + F / m).
struct DiskOnAdhesiveIncline {
  Model model;
  ContactModel cmodel;
  double angle, radius = 0.05;
  DiskOnAdhesiveIncline(double a, double mu, double force) : angle(a) {
    ModelBuilder mb("disk on an adhesive incline");
    const int carriage =
        mb.addBody(-1, "x", Joint::prismatic(Vector3::UnitX()), Pose{}, Inertia{}, "carriage");
    mb.addBody(carriage, "y", Joint::prismatic(Vector3::UnitY()), Pose{},
               Inertia{1.5, Vector3::Zero(), Matrix3::Identity() * 1e-3}, "mass");
    mb.setGravity(Vector3(0, -9.81, 0));
    model = mb.build();
    ContactModelBuilder cb(model);
    ContactLaw law{mu, 0.0};
    law.adhesion_force = force;
    cb.materials().setDefaultLaw(law);
    cb.addGeometry("mass", BodyRef::dynamic(model.bodyIndex("mass")), Pose::identity(),
                   Shape::disk(radius));
    Pose slope;
    slope.rotation = Eigen::AngleAxisd(a, Vector3::UnitZ()).toRotationMatrix();
    cb.addGeometry("slope", BodyRef::world(), slope, Shape::halfPlane());
    cmodel = cb.build();
  }
  VectorX start() const {
    const Vector3 p = radius * Vector3(-std::sin(angle), std::cos(angle), 0.0);
    VectorX q(2);
    q << p.x(), p.y();
    return q;
  }
  double along(const VectorX& q) const {  // down the slope
    return -(q[0] * std::cos(angle) + q[1] * std::sin(angle));
  }
};

TEST_P(Adhesion, ADiskOnAnInclineSticksOrSlidesByTheAdhesiveNormalForce) {
  const double m = 1.5, g = 9.81, mu = 0.3, a = 0.5, h = 1e-3;
  // sticks: the incline is steeper than atan(mu), the adhesion holds it
  const double F_stick = 1.1 * m * g * (std::tan(a) * std::cos(a) / mu - std::cos(a));
  {
    const DiskOnAdhesiveIncline scene(a, mu, F_stick);
    TimeStepper stepper(scene.model, scene.cmodel, settings(h));
    stepper.reset(0.0, scene.start(), VectorX::Zero(2));
    for (int k = 0; k < 2000; ++k) stepper.step();
    EXPECT_LT(std::abs(scene.along(stepper.q())), 1e-12);
  }
  // slides, slower than without adhesion by mu F / m
  const double F = 0.5;
  const DiskOnAdhesiveIncline scene(a, mu, F);
  TimeStepper stepper(scene.model, scene.cmodel, settings(h));
  stepper.reset(0.0, scene.start(), VectorX::Zero(2));
  for (int k = 0; k < 10; ++k) stepper.step();
  const Vector2 down(-std::cos(a), -std::sin(a));
  const double s0 = scene.along(stepper.q()), v0 = down.dot(stepper.v());
  const int steps = 1000;
  for (int k = 0; k < steps; ++k) stepper.step();
  const double acceleration = g * std::sin(a) - mu * (g * std::cos(a) + F / m);
  ASSERT_GT(acceleration, 0.0);
  const double T = steps * h;
  EXPECT_NEAR(down.dot(stepper.v()), v0 + acceleration * T, 1e-9 * acceleration * T);
  EXPECT_NEAR(scene.along(stepper.q()) - s0, v0 * T + 0.5 * acceleration * T * T,
              1e-9 * acceleration * T * T);
}

// In 2D a force is per unit thickness: the 3D law 4 pi gamma R* is refused, naming the pair.
TEST(AdhesionLaw, SurfaceEnergyIsRefusedIn2DAndNegativeValuesEverywhere) {
  ModelBuilder mb("disk");
  const int carriage =
      mb.addBody(-1, "x", Joint::prismatic(Vector3::UnitX()), Pose{}, Inertia{}, "carriage");
  mb.addBody(carriage, "y", Joint::prismatic(Vector3::UnitY()), Pose{},
             Inertia{1.0, Vector3::Zero(), Matrix3::Identity() * 1e-3}, "mass");
  const Model model = mb.build();
  ContactModelBuilder cb(model);
  ContactLaw law;
  law.surface_energy = 0.1;
  cb.materials().setDefaultLaw(law);
  cb.addGeometry("mass", BodyRef::dynamic(1), Pose::identity(), Shape::disk(0.05));
  cb.addGeometry("floor", BodyRef::world(), Pose::identity(), Shape::halfPlane());
  try {
    cb.build();
    FAIL() << "surface_energy accepted in 2D";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("surface_energy 0.1 is a 3D law"), std::string::npos)
        << e.what();
  }
  for (double ContactLaw::*field :
       {&ContactLaw::adhesion_force, &ContactLaw::surface_energy, &ContactLaw::adhesion_range}) {
    ContactLaw bad;
    bad.*field = -1.0;
    EXPECT_THROW(validateContactLaw(bad, "law"), InputError);
  }
}

INSTANTIATE_TEST_SUITE_P(Schemes, Adhesion,
                         ::testing::Values(Scheme::MoreauJean, Scheme::CatchingUp),
                         test::schemeTestName);

}  // namespace
}  // namespace sweep
