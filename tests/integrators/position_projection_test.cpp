// scheme.projection (integrators/position_projection.hpp): overlaps and passed joint limits
// pushed out at fixed velocities.
#include "integrators/position_projection.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "integrators/time_stepper.hpp"
#include "models/rigid_bodies.hpp"

namespace sweep {
namespace {

SchemeSettings projecting(Scheme scheme, int rounds) {
  SchemeSettings s;
  s.scheme = scheme;
  s.h = 1e-3;
  s.threads = 1;
  s.coulomb.tolerance = s.normal_stage.tolerance = s.friction_stage.tolerance = 1e-12;
  s.projection.max_rounds = rounds;
  s.projection.tolerance = 1e-3;
  return s;
}

// A ball of radius r (0.1 m), restitution e, sunk 4 mm into a floor, at rest.
struct SunkBall {
  static constexpr double r = 0.1, sunk = 0.004;
  Model model;
  ContactModel cmodel;
  VectorX q;
  explicit SunkBall(double e) {
    ModelBuilder mb("ball in floor");
    addFreeBody(mb, "ball", solidSphereInertia(2.0, r));
    mb.setGravity(Vector3(0, 0, -9.81));
    model = mb.build();
    ContactModelBuilder cb(model);
    cb.materials().setDefaultLaw({0.5, e});
    cb.addGeometry("ball", BodyRef::dynamic(0), Pose::identity(), Shape::sphere(r));
    cb.addGeometry("floor", BodyRef::world(), Pose::identity(), Shape::halfSpace());
    cmodel = cb.build();
    q = model.neutralConfiguration();
    q[2] = r - sunk;
  }
};

// A ball resting 4 mm into a floor under VEL: VEL keeps the overlap (its velocity stays 0),
// the projection puts the ball back to half the tolerance's overlap and leaves v as the step
// made it, to the bit.
TEST(PositionProjection, PushesAnOverlapOutAtFixedVelocities) {
  const SunkBall ball(0.0);
  const Model& model = ball.model;
  const ContactModel& cmodel = ball.cmodel;
  const VectorX& q = ball.q;
  const double r = SunkBall::r, sunk = SunkBall::sunk;
  for (Scheme scheme : {Scheme::MoreauJean, Scheme::CatchingUp}) {
    SCOPED_TRACE(enumName(scheme));
    TimeStepper plain(model, cmodel, projecting(scheme, 0));
    TimeStepper projected(model, cmodel, projecting(scheme, 3));
    plain.reset(0.0, q, VectorX::Zero(6));
    projected.reset(0.0, q, VectorX::Zero(6));
    EXPECT_EQ(plain.step().projection_rounds, 0);
    const StepStats& stats = projected.step();
    EXPECT_EQ(stats.projection_rounds, 1);  // a plane: one linear round is exact
    EXPECT_NEAR(plain.q()[2], r - sunk, 1e-12);
    EXPECT_NEAR(projected.q()[2], r - 0.5 * 1e-3 * r, 1e-12);
    EXPECT_EQ(projected.v(), plain.v());
    EXPECT_LE(stats.penetration_max, 1e-3 * r);
    // within the tolerance now: the next step does not project, and the ball stays
    EXPECT_EQ(projected.step().projection_rounds, 0);
    EXPECT_NEAR(projected.q()[2], r - 0.5 * 1e-3 * r, 1e-12);
  }
}

// With restitution the overlap is the last bounce's, and lifting it would hand the next
// rebound its potential energy: such a contact is held, not pushed out.
TEST(PositionProjection, LeavesContactsWithRestitutionWhereTheyAre) {
  const SunkBall ball(0.9);
  const Model& model = ball.model;
  const ContactModel& cmodel = ball.cmodel;
  const VectorX& q = ball.q;
  TimeStepper plain(model, cmodel, projecting(Scheme::MoreauJean, 0));
  TimeStepper projected(model, cmodel, projecting(Scheme::MoreauJean, 3));
  plain.reset(0.0, q, VectorX::Zero(6));
  projected.reset(0.0, q, VectorX::Zero(6));
  plain.step();
  EXPECT_EQ(projected.step().projection_rounds, 0);
  EXPECT_EQ(projected.q(), plain.q());
}

// Two balls stacked on the floor, both sunk: the projection solves the coupled program.
TEST(PositionProjection, ACoupledStackIsLiftedTogether) {
  const double r = 0.05, h = 1e-3;
  ModelBuilder mb("stack");
  addFreeBody(mb, "lower", solidSphereInertia(1.0, r));
  addFreeBody(mb, "upper", solidSphereInertia(1.0, r));
  mb.setGravity(Vector3(0, 0, -9.81));
  const Model model = mb.build();
  ContactModelBuilder cb(model);
  cb.materials().setDefaultLaw({0.0, 0.0});
  cb.addGeometry("lower", BodyRef::dynamic(0), Pose::identity(), Shape::sphere(r));
  cb.addGeometry("upper", BodyRef::dynamic(1), Pose::identity(), Shape::sphere(r));
  cb.addGeometry("floor", BodyRef::world(), Pose::identity(), Shape::halfSpace());
  const ContactModel cmodel = cb.build();
  VectorX q = model.neutralConfiguration();
  q[2] = r - 0.002;
  q[7 + 2] = 3.0 * r - 0.002 - 0.003;  // 2 mm into the floor, 3 mm into the lower ball
  for (Scheme scheme : {Scheme::MoreauJean, Scheme::CatchingUp}) {
    SCOPED_TRACE(enumName(scheme));
    SchemeSettings s = projecting(scheme, 3);
    s.h = h;
    TimeStepper stepper(model, cmodel, s);
    stepper.reset(0.0, q, VectorX::Zero(12));
    stepper.step();
    // each overlap within the tolerance (1e-3 of the radius), none opened into a gap: the
    // upper ball rose by the lower one's lift plus its own overlap
    const double allowed = 1e-3 * r, lower = stepper.q()[2], upper = stepper.q()[7 + 2];
    EXPECT_GE(r - lower, 0.0);
    EXPECT_LE(r - lower, allowed);
    EXPECT_GE(2.0 * r - (upper - lower), 0.0);
    EXPECT_LE(2.0 * r - (upper - lower), allowed);
    EXPECT_TRUE(stepper.v().allFinite());
  }
}

// A pendulum started 0.05 rad past its upper joint limit: the projection puts it back within
// the tolerance (rad), where VEL alone leaves it past the limit.
TEST(PositionProjection, APassedJointLimitIsRestored) {
  ModelBuilder mb("pendulum");
  const int link = mb.addBody(-1, "hinge", Joint::revolute(Vector3::UnitY()), Pose{},
                              solidBoxInertia(1.0, Vector3(0.02, 0.02, 0.5)), "link");
  mb.addJointLimits(link, -0.5, 0.5);
  mb.setGravity(Vector3(0, 0, -9.81));
  const Model model = mb.build();
  const ContactModel cmodel = ContactModelBuilder(model).build();
  VectorX q = model.neutralConfiguration();
  q[0] = 0.55;
  for (Scheme scheme : {Scheme::MoreauJean, Scheme::CatchingUp}) {
    SCOPED_TRACE(enumName(scheme));
    TimeStepper plain(model, cmodel, projecting(scheme, 0));
    TimeStepper projected(model, cmodel, projecting(scheme, 3));
    plain.reset(0.0, q, VectorX::Zero(1));
    projected.reset(0.0, q, VectorX::Zero(1));
    plain.step();
    projected.step();
    EXPECT_GT(plain.q()[0], 0.549);
    // no shape: the tolerance is absolute, 1e-3 rad, and the limit keeps half of it
    EXPECT_NEAR(projected.q()[0], 0.5 + 0.5e-3, 1e-9);
    EXPECT_EQ(projected.v(), plain.v());
  }
}

}  // namespace
}  // namespace sweep
