#include "models/archetypes.hpp"

#include <cmath>

#include "models/kinematic_trees.hpp"
#include "models/rigid_bodies.hpp"

namespace sweep {

namespace {

// A link of a planar mechanism given by its mass, centre and moment J about the centre
// (the published data): only the z moment acts in the plane, so all three are J.
Inertia planarLink(double mass, const Vector3& com, double J) {
  Inertia in;
  in.mass = mass;
  in.com = com;
  in.inertia_com = J * Matrix3::Identity();
  return in;
}

}  // namespace

Scene bouncingBall(const BouncingBallParameters& p) {
  ModelBuilder mb("bouncing ball");
  addFreeBody(mb, "ball", solidSphereInertia(p.mass, p.radius));
  mb.setGravity(Vector3(0.0, 0.0, -p.gravity));
  Scene scene;
  scene.model = mb.build();
  ContactModelBuilder cb(scene.model);
  cb.materials().setDefaultLaw({0.0, p.restitution});
  cb.addGeometry("ball", BodyRef::dynamic(0), Pose::identity(), Shape::sphere(p.radius));
  cb.addGeometry("floor", BodyRef::world(), Pose::identity(), Shape::halfSpace());
  scene.cmodel = cb.build();
  scene.q0 = scene.model.neutralConfiguration();
  scene.q0[2] = p.drop + p.radius;
  scene.v0 = VectorX::Zero(scene.model.nv);
  return scene;
}

std::vector<double> bouncingBallImpactTimes(const BouncingBallParameters& p, int count) {
  const double t1 = std::sqrt(2.0 * p.drop / p.gravity), v1 = p.gravity * t1;
  std::vector<double> times;
  double sum = 0.0;
  for (int n = 0; n < count; ++n) {
    if (n > 0) sum += std::pow(p.restitution, n);
    times.push_back(t1 + 2.0 * v1 / p.gravity * sum);
  }
  return times;
}

Scene rockingBlock(const RockingBlockParameters& p) {
  const double b = p.half_width, c = p.half_height;
  ModelBuilder mb("rocking block");
  addPlanarBody(mb, "block", solidBoxInertia(p.mass, Vector3(2.0 * b, 2.0 * c, 0.01)));
  mb.setGravity(Vector3(0.0, -p.gravity, 0.0));
  Scene scene;
  scene.model = mb.build();
  ContactModelBuilder cb(scene.model);
  cb.materials().setDefaultLaw({p.friction, 0.0});
  cb.addGeometry("block", BodyRef::dynamic(0), Pose::identity(),
                 Shape::polygon({{-b, -c}, {b, -c}, {b, c}, {-b, c}}));
  cb.addGeometry("floor", BodyRef::world(), Pose::identity(), Shape::halfPlane());
  scene.cmodel = cb.build();
  // the bottom-right corner (b, -c), rotated by the tilt, sits at the origin
  const Eigen::Rotation2Dd R(p.tilt);
  const Vector2 centre = -(R * Vector2(b, -c));
  scene.q0 = Vector3(centre.x(), centre.y(), p.tilt);
  scene.v0 = VectorX::Zero(3);
  return scene;
}

double housnerRatio(const RockingBlockParameters& p) {
  const double s = std::atan(p.half_width / p.half_height);
  return 1.0 - 1.5 * std::sin(s) * std::sin(s);
}

Scene wallPendulum(const WallPendulumParameters& p) {
  DoublePendulumParameters pendulum;
  pendulum.m1 = p.m1;
  pendulum.m2 = p.m2;
  pendulum.l1 = p.l1;
  pendulum.l2 = p.l2;
  pendulum.g = p.gravity;
  // one bob inertia for both links: the URDF twin states 1.6e-4 for each 1 kg bob
  pendulum.tip_inertia = 0.4 * p.m1 * p.bob_radius * p.bob_radius;
  Scene scene;
  scene.model = doublePendulum(pendulum);
  ContactModelBuilder cb(scene.model);
  MaterialTable& materials = cb.materials();
  const int bouncy = materials.add("bouncy"), plastic = materials.add("plastic"),
            wall = materials.add("wall");
  materials.setDefaultLaw({0.0, 0.0});
  materials.setLaw(bouncy, wall, {0.0, p.e_upper});
  materials.setLaw(plastic, wall, {0.0, p.e_lower});
  Pose upper_bob, lower_bob;
  upper_bob.translation = Vector3(0.0, -p.l1, 0.0);
  lower_bob.translation = Vector3(0.0, -p.l2, 0.0);
  cb.addGeometry("upper bob", BodyRef::dynamic(0), upper_bob, Shape::sphere(p.bob_radius), bouncy);
  cb.addGeometry("lower bob", BodyRef::dynamic(1), lower_bob, Shape::sphere(p.bob_radius), plastic);
  Pose face;  // the half-space's outward normal, local +z, turned to +x
  face.rotation = Eigen::AngleAxisd(0.5 * M_PI, Vector3::UnitY()).toRotationMatrix();
  face.translation = Vector3(-p.bob_radius, 0.0, 0.0);
  cb.addGeometry("wall", BodyRef::world(), face, Shape::halfSpace(), wall);
  scene.cmodel = cb.build();
  scene.q0 = Eigen::Vector2d(p.theta1, p.theta2 - p.theta1);
  scene.v0 = VectorX::Zero(2);
  return scene;
}

Scene sliderCrank(const SliderCrankParameters& p) {
  ModelBuilder mb("slider-crank with clearance");
  mb.setGravity(Vector3(0.0, -p.gravity, 0.0));
  Pose at_crank_pin, at_rod_end;
  at_crank_pin.translation = Vector3(p.l1, 0.0, 0.0);
  at_rod_end.translation = Vector3(p.l2, 0.0, 0.0);
  const int crank = mb.addBody(-1, "crank joint", Joint::revolute(Vector3::UnitZ()), Pose{},
                               planarLink(p.m1, Vector3(0.5 * p.l1, 0, 0), p.J1), "crank");
  const int rod = mb.addBody(crank, "crank pin", Joint::revolute(Vector3::UnitZ()), at_crank_pin,
                             planarLink(p.m2, Vector3(0.5 * p.l2, 0, 0), p.J2), "rod");
  mb.addBody(rod, "piston pin", Joint::revolute(Vector3::UnitZ()), at_rod_end,
             planarLink(p.m3, Vector3::Zero(), p.J3), "slider");
  Scene scene;
  scene.model = mb.build();
  ContactModelBuilder cb(scene.model);
  cb.materials().setDefaultLaw({p.friction, p.restitution});
  const double a = p.slider_half_length, b = p.slider_half_width;
  cb.addGeometry("slider", BodyRef::dynamic(2), Pose::identity(),
                 Shape::polygon({{-a, -b}, {a, -b}, {a, b}, {-a, b}}));
  const double half_gap = b + p.clearance;
  Pose lower, upper;  // half-planes: outward normal local +y
  lower.translation = Vector3(0.0, -half_gap, 0.0);
  upper.translation = Vector3(0.0, half_gap, 0.0);
  upper.rotation = Eigen::AngleAxisd(M_PI, Vector3::UnitZ()).toRotationMatrix();
  cb.addGeometry("lower guide", BodyRef::world(), lower, Shape::halfPlane());
  cb.addGeometry("upper guide", BodyRef::world(), upper, Shape::halfPlane());
  scene.cmodel = cb.build();
  scene.q0 = VectorX::Zero(3);
  // relative joint rates from the absolute ones
  scene.v0 = Vector3(p.omega[0], p.omega[1] - p.omega[0], p.omega[2] - p.omega[1]);
  return scene;
}

Scene woodpecker(const WoodpeckerParameters& p) {
  ModelBuilder mb("woodpecker toy");
  mb.setGravity(Vector3(0.0, -p.gravity, 0.0));
  const int carriage = mb.addBody(-1, "pole slide", Joint::prismatic(Vector3::UnitY()), Pose{},
                                  Inertia::zero(), "carriage");
  const int sleeve = mb.addBody(carriage, "sleeve tilt", Joint::revolute(Vector3::UnitZ()), Pose{},
                                planarLink(p.mM, Vector3::Zero(), p.JM), "sleeve");
  Pose spring;
  spring.translation = Vector3(p.lM, 0.0, 0.0);
  const int bird = mb.addBody(sleeve, "spring", Joint::revolute(Vector3::UnitZ()), spring,
                              planarLink(p.mS, Vector3(p.lG, 0.0, 0.0), p.JS), "bird");
  Scene scene;
  scene.model = mb.build();
  ContactModelBuilder cb(scene.model);
  MaterialTable& materials = cb.materials();
  const int beak = materials.add("beak"), sleeve_edge = materials.add("sleeve"),
            pole = materials.add("pole");
  materials.setDefaultLaw({p.friction, 0.0});
  materials.setLaw(beak, pole, {p.friction, p.e_beak});
  materials.setLaw(sleeve_edge, pole, {p.friction, p.e_sleeve});
  const double r = p.point_radius;
  auto point = [&](double x, double y) {
    Pose at;
    at.translation = Vector3(x + r, y, 0.0);
    return at;
  };
  cb.addGeometry("sleeve lower edge", BodyRef::dynamic(sleeve), point(p.rM, -p.hM), Shape::disk(r),
                 sleeve_edge);
  cb.addGeometry("sleeve upper edge", BodyRef::dynamic(sleeve), point(p.rM, p.hM), Shape::disk(r),
                 sleeve_edge);
  cb.addGeometry("beak", BodyRef::dynamic(bird), point(p.lG - p.lS, p.hS), Shape::disk(r), beak);
  Pose face;  // the half-plane's outward normal, local +y, turned to +x
  face.rotation = Eigen::AngleAxisd(-0.5 * M_PI, Vector3::UnitZ()).toRotationMatrix();
  face.translation = Vector3(p.r0, 0.0, 0.0);
  cb.addGeometry("pole", BodyRef::world(), face, Shape::halfPlane(), pole);
  scene.cmodel = cb.build();
  // the sleeve starts jammed on its lower edge: solve rM cos(phi) + hM sin(phi) for the edge
  // position the linear model gives, rM + hM phi_M0, so that the start gap is Glocker's
  // (-9e-7 m) and not the -1.6e-5 m the cosine would add
  const double target = p.rM + p.hM * p.q0[1];
  double phi_M = p.q0[1];
  for (int k = 0; k < 20; ++k)
    phi_M -= (p.rM * std::cos(phi_M) + p.hM * std::sin(phi_M) - target) /
             (-p.rM * std::sin(phi_M) + p.hM * std::cos(phi_M));
  scene.q0 = Vector3(p.q0[0], phi_M, p.q0[2] - phi_M);
  scene.v0 = Vector3(p.v0[0], p.v0[1], p.v0[2] - p.v0[1]);
  const double c = p.c_phi;
  scene.forces = [c](double, const VectorX& q, const VectorX&, VectorX& tau) {
    tau[2] -= c * q[2];
  };
  return scene;
}

}  // namespace sweep
