// A planar body and 3D bodies restricted to the plane must move identically.
#include <gtest/gtest.h>

#include "integrators/smooth_reference.hpp"
#include "models/rigid_bodies.hpp"

namespace sweep {
namespace {

// box with its frame off the centre of mass, so M(q) is not constant for any of the forms
Inertia offCentreBox() {
  Inertia in = solidBoxInertia(2.0, Vector3(0.4, 0.2, 0.1));
  in.com = Vector3(0.1, 0.05, 0.0);
  return in;
}

Model planarModel() {
  ModelBuilder b("planar");
  b.setGravity(Vector3(0, -9.81, 0));
  addPlanarBody(b, "box", offCentreBox());
  return b.build();
}

// x slider -> y slider -> z hinge, with massless intermediate links: a 3D tree confined to xy
Model sliderChainModel() {
  ModelBuilder b("slider chain");
  b.setGravity(Vector3(0, -9.81, 0));
  const int sx =
      b.addBody(-1, "x", Joint::prismatic(Vector3::UnitX()), Pose{}, Inertia::zero(), "sx");
  const int sy =
      b.addBody(sx, "y", Joint::prismatic(Vector3::UnitY()), Pose{}, Inertia::zero(), "sy");
  b.addBody(sy, "theta", Joint::revolute(Vector3::UnitZ()), Pose{}, offCentreBox(), "box");
  return b.build();
}

Model freeModel() {
  ModelBuilder b("free");
  b.setGravity(Vector3(0, -9.81, 0));
  addFreeBody(b, "box", offCentreBox());
  return b.build();
}

TEST(PlanarConsistency, PlanarJointSliderChainAndFreeBodyAgree) {
  const double x0 = 0.3, y0 = 1.0, th0 = 0.4, vx = 1.5, vy = 2.0, w = 7.0;
  const Model planar = planarModel(), chain = sliderChainModel(), free = freeModel();
  VectorX qp(3), vp(3);
  qp << x0, y0, th0;
  vp << vx, vy, w;
  VectorX qf(7), vf(6);
  const Quaternion rot(Eigen::AngleAxisd(th0, Vector3::UnitZ()));
  qf << x0, y0, 0.0, rot.x(), rot.y(), rot.z(), rot.w();
  vf << vx, vy, 0.0, 0.0, 0.0, w;

  SmoothReferenceIntegrator a(planar), b(chain), c(free);
  a.reset(0.0, qp, vp);
  b.reset(0.0, qp, vp);
  c.reset(0.0, qf, vf);
  for (double t : {0.5, 1.0, 2.0}) {
    a.advanceTo(t);
    b.advanceTo(t);
    c.advanceTo(t);
    EXPECT_LT((a.q() - b.q()).norm(), 1e-9) << "t = " << t;
    EXPECT_LT((a.v() - b.v()).norm(), 1e-9) << "t = " << t;
    EXPECT_NEAR(c.q()[0], a.q()[0], 1e-9);
    EXPECT_NEAR(c.q()[1], a.q()[1], 1e-9);
    EXPECT_NEAR(c.q()[2], 0.0, 1e-12);  // never leaves the plane
    const Quaternion qa(Eigen::AngleAxisd(a.q()[2], Vector3::UnitZ()));
    const Quaternion qc(c.q()[6], c.q()[3], c.q()[4], c.q()[5]);
    EXPECT_LT(qa.angularDistance(qc), 1e-9);
    EXPECT_NEAR(c.v()[5], a.v()[2], 1e-9);
  }
  // the motion is not trivial: the box spun several turns while falling
  EXPECT_GT(std::abs(a.q()[2] - th0), 6.0);
}

}  // namespace
}  // namespace sweep
