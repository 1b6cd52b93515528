#include "models/kinematic_trees.hpp"

namespace sweep {

namespace {

Pose offset(const Vector3& xyz, const Vector3& rpy = Vector3::Zero()) {
  Pose p;
  p.translation = xyz;
  // URDF convention: R = Rz(yaw) Ry(pitch) Rx(roll)
  p.rotation =
      (Eigen::AngleAxisd(rpy.z(), Vector3::UnitZ()) * Eigen::AngleAxisd(rpy.y(), Vector3::UnitY()) *
       Eigen::AngleAxisd(rpy.x(), Vector3::UnitX()))
          .toRotationMatrix();
  return p;
}

Inertia link(double mass, const Vector3& com, const Vector3& moments, const Vector3& products) {
  Inertia in;
  in.mass = mass;
  in.com = com;
  in.inertia_com << moments.x(), products.x(), products.y(), products.x(), moments.y(),
      products.z(), products.y(), products.z(), moments.z();
  return in;
}

}  // namespace

Model doublePendulum(const DoublePendulumParameters& p) {
  ModelBuilder b("double pendulum");
  b.setGravity(Vector3(0, -p.g, 0));
  const Vector3 tip_moments = Vector3::Constant(p.tip_inertia);
  const int upper =
      b.addBody(-1, "shoulder", Joint::revolute(Vector3::UnitZ()), Pose{},
                link(p.m1, Vector3(0, -p.l1, 0), tip_moments, Vector3::Zero()), "upper");
  b.addBody(upper, "elbow", Joint::revolute(Vector3::UnitZ()), offset(Vector3(0, -p.l1, 0)),
            link(p.m2, Vector3(0, -p.l2, 0), tip_moments, Vector3::Zero()), "lower");
  return b.build();
}

Model serialArm6() {
  ModelBuilder b("6-dof arm");
  b.setGravity(Vector3(0, 0, -9.81));
  const Vector3 axes[6] = {Vector3::UnitZ(), Vector3::UnitY(), Vector3::UnitY(),
                           Vector3::UnitX(), Vector3::UnitY(), Vector3::UnitX()};
  const Pose offsets[6] = {offset({0, 0, 0.1}),
                           offset({0, 0.05, 0.2}, {0.1, 0, 0}),
                           offset({0.35, 0, 0}, {0, 0.2, 0}),
                           offset({0.3, 0, 0.02}, {0, 0, 0.3}),
                           offset({0.1, 0, 0}, {0.2, -0.1, 0}),
                           offset({0.08, 0, 0}, {0, 0, -0.25})};
  const double masses[6] = {4.0, 3.0, 2.0, 1.2, 0.8, 0.3};
  int parent = -1;
  for (int i = 0; i < 6; ++i) {
    const double m = masses[i];
    const Inertia in = link(m, Vector3(0.05 + 0.01 * i, 0.01, -0.02 * i),
                            m * Vector3(0.010, 0.012, 0.009), m * Vector3(0.001, -0.0005, 0.0008));
    parent = b.addBody(parent, "joint" + std::to_string(i + 1), Joint::revolute(axes[i]),
                       offsets[i], in, "link" + std::to_string(i + 1));
  }
  return b.build();
}

Model branchedTree(int n_bodies) {
  ModelBuilder b("branched tree");
  for (int i = 0; i < n_bodies; ++i) {
    // body i hangs from body (i - 1) / 2: a binary tree in breadth-first numbering
    const int parent = i == 0 ? -1 : (i - 1) / 2;
    const Vector3 axis =
        (i % 3 == 0) ? Vector3::UnitZ() : (i % 3 == 1 ? Vector3::UnitY() : Vector3::UnitX());
    const double side = (i % 2 == 0) ? 1.0 : -1.0;
    const Pose placement =
        i == 0 ? Pose{} : offset(Vector3(0.2, 0.1 * side, -0.05), Vector3(0.1 * side, 0.05, 0));
    const Inertia in = link(1.0 / (1 + i % 4), Vector3(0.1, 0.0, 0.01), Vector3(0.01, 0.012, 0.011),
                            Vector3(0.001, 0.0, -0.0005));
    b.addBody(parent, "j" + std::to_string(i), Joint::revolute(axis), placement, in,
              "b" + std::to_string(i));
  }
  return b.build();
}

}  // namespace sweep
