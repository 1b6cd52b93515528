// Contact Jacobian rows against finite differences: W_N^T v + known is the rate of the gap
// along (v, t), and W_T^T v + known the tangential velocity of the witness points.
#include "contact/contact_jacobian.hpp"

#include <gtest/gtest.h>

#include <algorithm>

#include "contact_test_scenes.hpp"
#include "framework/configuration.hpp"
#include "framework/jacobian.hpp"
#include "framework/urdf_import.hpp"

namespace sweep {
namespace {

struct Scene {
  Model model;
  ContactModel cmodel;
  VectorX q;
};

// Checks every contact of the scene at (q, v, t). Central differences of step eps = 1e-4:
// truncation, O(eps^2 |v|^2 / radius), and GJK tolerance / eps both stay below 1e-7.
void expectRatesMatch(const Scene& s, const VectorX& v, double t, double margin,
                      std::size_t expected_contacts) {
  const Model& model = s.model;
  Data data(model);
  ContactData cdata(model, s.cmodel);
  forwardKinematics(model, data, s.q);
  detectContacts(model, data, s.cmodel, cdata, t, margin);
  ASSERT_EQ(cdata.contacts.size(), expected_contacts);
  assembleContactJacobian(model, data, s.cmodel, cdata, t);
  const std::vector<Contact> contacts = cdata.contacts;
  const ContactJacobian J = cdata.jacobian;

  // material points of the witness points, carried along by their bodies
  auto worldPoint = [&](const Data& d, const BodyRef& body, const Vector3& local, double time) {
    switch (body.kind) {
      case BodyRef::Kind::Dynamic:
        return d.world_pose[body.index].apply(local);
      case BodyRef::Kind::Driven:
        return model.driven_bodies[body.index].pose(time).apply(local);
      default:
        return local;
    }
  };
  auto localPoint = [&](const BodyRef& body, const Vector3& world) {
    switch (body.kind) {
      case BodyRef::Kind::Dynamic:
        return data.world_pose[body.index].inverse().apply(world);
      case BodyRef::Kind::Driven:
        return model.driven_bodies[body.index].pose(t).inverse().apply(world);
      default:
        return world;
    }
  };

  const double eps = 1e-4;
  Data shifted(model);
  ContactData cshift(model, s.cmodel);
  std::vector<double> gap[2];
  std::vector<Vector3> pa[2], pb[2];
  for (int side = 0; side < 2; ++side) {
    const double sign = side == 0 ? 1.0 : -1.0;
    const VectorX q = integrate(model, s.q, sign * eps * v);
    forwardKinematics(model, shifted, q);
    detectContacts(model, shifted, s.cmodel, cshift, t + sign * eps, margin);
    for (const Contact& c : contacts) {
      double g = std::nan("");
      for (const Contact& d : cshift.contacts)
        if (d.key == c.key) g = d.gap;
      gap[side].push_back(g);
      pa[side].push_back(
          worldPoint(shifted, c.body_a, localPoint(c.body_a, c.point_a), t + sign * eps));
      pb[side].push_back(
          worldPoint(shifted, c.body_b, localPoint(c.body_b, c.point_b), t + sign * eps));
    }
  }
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    const Vector3 u = J.relativeVelocity(static_cast<int>(c), v);
    const double rate = (gap[0][c] - gap[1][c]) / (2 * eps);
    const Vector3 relative = ((pb[0][c] - pb[1][c]) - (pa[0][c] - pa[1][c])) / (2 * eps);
    const double scale = 1.0 + v.norm();
    EXPECT_NEAR(u.x(), rate, 1e-6 * scale) << "contact " << c;
    EXPECT_NEAR(u.x(), contacts[c].normal.dot(relative), 1e-6 * scale) << "contact " << c;
    EXPECT_NEAR(u.y(), contacts[c].tangent1.dot(relative), 1e-6 * scale) << "contact " << c;
    EXPECT_NEAR(u.z(), contacts[c].tangent2.dot(relative), 1e-6 * scale) << "contact " << c;
    // sparse: only the dofs of the bodies involved
    for (int k = J.begin[c]; k < J.begin[c + 1]; ++k) {
      const int body_of_dof = [&] {
        for (int b = 0; b < static_cast<int>(model.bodies.size()); ++b) {
          const Body& body = model.bodies[b];
          if (J.dof[k] >= body.v_index && J.dof[k] < body.v_index + body.joint.nv()) return b;
        }
        return -1;
      }();
      const Contact& ct = contacts[c];
      bool moves_a_point = false;
      for (const BodyRef& ref : {ct.body_a, ct.body_b})
        for (int b = ref.kind == BodyRef::Kind::Dynamic ? ref.index : -1; b >= 0;
             b = model.bodies[b].parent)
          moves_a_point = moves_a_point || b == body_of_dof;
      EXPECT_TRUE(moves_a_point) << "dof " << J.dof[k] << " of contact " << c;
    }
  }

  // rows for closed contacts only (the VEL law's): an open contact gets no entries and no
  // known velocity, a closed one the very entries it had
  const double max_gap = 0.5 * (contacts.front().gap + contacts.back().gap);
  assembleContactJacobian(model, data, s.cmodel, cdata, t, max_gap);
  const ContactJacobian& closed = cdata.jacobian;
  ASSERT_EQ(closed.size(), J.size());
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    const int n = closed.begin[c + 1] - closed.begin[c];
    if (contacts[c].gap > max_gap) {
      EXPECT_EQ(n, 0) << "contact " << c;
      EXPECT_EQ(closed.known_velocity[c], Vector3::Zero()) << "contact " << c;
      continue;
    }
    ASSERT_EQ(n, J.begin[c + 1] - J.begin[c]) << "contact " << c;
    EXPECT_EQ(closed.known_velocity[c], J.known_velocity[c]) << "contact " << c;
    for (int k = 0; k < n; ++k) {
      EXPECT_EQ(closed.dof[closed.begin[c] + k], J.dof[J.begin[c] + k]);
      EXPECT_EQ(closed.normal[closed.begin[c] + k], J.normal[J.begin[c] + k]);
      EXPECT_EQ(closed.tangent1[closed.begin[c] + k], J.tangent1[J.begin[c] + k]);
      EXPECT_EQ(closed.tangent2[closed.begin[c] + k], J.tangent2[J.begin[c] + k]);
    }
  }
}

VectorX randomVelocity(int nv, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  VectorX v(nv);
  for (int i = 0; i < nv; ++i) v[i] = u(rng);
  return v;
}

TEST(ContactJacobian, PlanarBodies) {
  // a disk, a segment and a triangle on planar bodies; a half-plane floor in the world
  const std::vector<Shape> shapes = {Shape::disk(0.5),
                                     Shape::segment({-1.0, 0.0}, {1.0, 0.0}, 0.05),
                                     Shape::polygon({{-0.5, -0.3}, {0.5, -0.3}, {0.0, 0.6}})};
  test::ShapeScene shape_scene = test::shapeScene(shapes);
  for (DetectionPathChoice path : {DetectionPathChoice::Automatic, DetectionPathChoice::Fcl}) {
    ContactModelBuilder builder(shape_scene.model);
    DetectionSettings settings;
    settings.path = path;
    builder.setSettings(settings);
    for (int i = 0; i < 3; ++i)
      builder.addGeometry("s" + std::to_string(i), BodyRef::dynamic(i), Pose::identity(),
                          shapes[i]);
    builder.addGeometry("floor", BodyRef::world(), Pose::identity(), Shape::halfPlane());
    Scene s{shape_scene.model, builder.build(), shape_scene.model.neutralConfiguration()};
    // segment under the disk, tilted; triangle resting on the floor, rotated a little
    s.q.segment<3>(0) << 0.1, 0.56, 0.0;
    s.q.segment<3>(3) << 0.2, 0.0, 0.05;
    s.q.segment<3>(6) << 3.0, 0.31, 0.02;
    // disk-segment, disk-floor (gap 0.06), segment-floor (2 ends), triangle-floor (2 corners)
    const std::size_t expected = 6;
    SCOPED_TRACE(s.cmodel.path_reason);
    if (path == DetectionPathChoice::Automatic) {
      // a polygon meets a segment by type: the scene needs the general path
      EXPECT_EQ(s.cmodel.path, DetectionPath::Fcl);
    }
    expectRatesMatch(s, randomVelocity(s.model.nv, 1), 0.0, 0.1, expected);
  }
}

TEST(ContactJacobian, FreeBodiesWithQuaternions) {
  // a box and a sphere on free bodies, both spinning: sphere-box has a closed form, and so
  // has a capsule against the box (the box's surface mesh): both of its ends within the margin
  const std::vector<Shape> shapes = {Shape::box(Vector3(1.0, 0.8, 0.6)), Shape::sphere(0.3),
                                     Shape::capsule(0.2, 0.6)};
  const test::ShapeScene shape_scene = test::shapeScene(shapes);
  ContactModelBuilder builder(shape_scene.model);
  for (int i = 0; i < 3; ++i)
    builder.addGeometry("s" + std::to_string(i), BodyRef::dynamic(i), Pose::identity(), shapes[i]);
  Scene s{shape_scene.model, builder.build(), shape_scene.model.neutralConfiguration()};
  std::mt19937 rng(3);
  test::placeBody(s.model, s.q, 0, Vector3::Zero(), test::randomOrientation(rng, false));
  test::placeBody(s.model, s.q, 1, Vector3(0.0, 0.0, 1.1), Quaternion::Identity());
  test::placeBody(s.model, s.q, 2, Vector3(1.2, 0.0, 0.0), test::randomOrientation(rng, false));
  expectRatesMatch(s, randomVelocity(s.model.nv, 2), 0.0, 0.8, 3);
}

TEST(ContactJacobian, UrdfArmTouchingABox) {
  Model arm = loadUrdf(std::string(SWEEP_TEST_DATA) + "/urdf/arm6.urdf");
  ContactModelBuilder builder(arm);
  builder.addModelCollisions();
  // a table under the arm's reach; its top meets the forearm (link3 mesh, link4 sphere)
  Pose table;
  table.translation = Vector3(0.35, 0.0, 0.0);
  const int table_id =
      builder.addGeometry("table", BodyRef::world(), table, Shape::box(Vector3(0.4, 0.6, 0.1)));
  ContactModel cmodel = builder.build();
  EXPECT_EQ(cmodel.path, DetectionPath::Fcl);
  VectorX q = arm.neutralConfiguration();
  q.head(3) << 0.3, 1.2, 0.5;
  // lift the table so that its top sits just under the lowest arm geometry
  Data data(arm);
  forwardKinematics(arm, data, q);
  ContactData cdata(arm, cmodel);
  detectContacts(arm, data, cmodel, cdata, 0.0, 10.0);
  double lowest = 1e9;
  for (const Contact& c : cdata.contacts)
    if (c.key.geometry_b == table_id || c.key.geometry_a == table_id)
      lowest = std::min(lowest, c.gap);
  ASSERT_LT(lowest, 1e8);
  cmodel.geometries[table_id].placement.translation.z() += lowest - 0.01;
  Scene s{arm, cmodel, q};
  const VectorX v = randomVelocity(arm.nv, 4);
  Data d2(arm);
  forwardKinematics(arm, d2, q);
  ContactData c2(arm, cmodel);
  detectContacts(arm, d2, cmodel, c2, 0.0, 0.05);
  ASSERT_GE(c2.contacts.size(), 1u);
  expectRatesMatch(s, v, 0.0, 0.05, c2.contacts.size());
}

// The arm's links against each other (self-collision): two sides in one tree share the
// columns of their common ancestors, merged into one entry per dof, and the row gives the
// relative velocity of the witness points that the dense point Jacobians give. (The gap's
// rate by finite differences is no check here: the links' meshes overlap at their joints,
// where the distance is a penetration depth with kinks.)
TEST(ContactJacobian, SelfCollisionMergesTheCommonChain) {
  Model arm = loadUrdf(std::string(SWEEP_TEST_DATA) + "/urdf/arm6.urdf");
  ContactModelBuilder builder(arm);
  DetectionSettings settings;
  settings.self_collision = true;
  builder.setSettings(settings);
  builder.addModelCollisions();
  const ContactModel cmodel = builder.build();
  VectorX q = arm.neutralConfiguration();
  q.head(3) << 0.3, 1.2, 0.5;
  Data data(arm);
  forwardKinematics(arm, data, q);
  ContactData cdata(arm, cmodel);
  detectContacts(arm, data, cmodel, cdata, 0.0, 0.5);
  assembleContactJacobian(arm, data, cmodel, cdata, 0.0);
  const ContactJacobian& J = cdata.jacobian;
  const VectorX v = randomVelocity(arm.nv, 7);
  int shared = 0;
  for (std::size_t c = 0; c < cdata.contacts.size(); ++c) {
    const Contact& contact = cdata.contacts[c];
    ASSERT_EQ(contact.body_a.kind, BodyRef::Kind::Dynamic);
    ASSERT_EQ(contact.body_b.kind, BodyRef::Kind::Dynamic);
    std::vector<int> dofs(J.dof.begin() + J.begin[c], J.dof.begin() + J.begin[c + 1]);
    std::sort(dofs.begin(), dofs.end());
    // the union of the two chains' dofs, each once
    std::vector<int> chains;
    for (const BodyRef& body : {contact.body_a, contact.body_b})
      for (int b = body.index; b >= 0; b = arm.bodies[b].parent)
        for (int k = 0; k < arm.bodies[b].joint.nv(); ++k)
          chains.push_back(arm.bodies[b].v_index + k);
    std::sort(chains.begin(), chains.end());
    const std::size_t both = chains.size();
    chains.erase(std::unique(chains.begin(), chains.end()), chains.end());
    EXPECT_EQ(dofs, chains) << "contact " << c;
    shared += chains.size() < both;
    Eigen::Matrix<double, 6, Eigen::Dynamic> Ja =
        Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, arm.nv);
    Eigen::Matrix<double, 6, Eigen::Dynamic> Jb = Ja;
    pointJacobian(arm, data, contact.body_a.index, contact.point_a, Ja);
    pointJacobian(arm, data, contact.body_b.index, contact.point_b, Jb);
    const Vector3 relative = (Jb.bottomRows<3>() - Ja.bottomRows<3>()) * v;
    const Vector3 u = J.relativeVelocity(static_cast<int>(c), v);
    const double scale = 1e-12 * (1.0 + relative.norm());
    EXPECT_NEAR(u.x(), contact.normal.dot(relative), scale) << "contact " << c;
    EXPECT_NEAR(u.y(), contact.tangent1.dot(relative), scale) << "contact " << c;
    EXPECT_NEAR(u.z(), contact.tangent2.dot(relative), scale) << "contact " << c;
  }
  EXPECT_GE(shared, 1);  // some pairs share a chain: the merge is exercised
}

TEST(ContactJacobian, DrivenBodyEntersAsKnownVelocity) {
  // a spinning, translating driven box against a free sphere: the gap changes even at v = 0
  ModelBuilder mb("driven");
  addFreeBody(mb, "ball", solidSphereInertia(1.0, 0.3));
  Pose start;
  start.translation = Vector3(0, 0, -0.5);
  mb.addDrivenBody(
      DrivenBody::constantTwist("pusher", start, Vector3(0.3, -0.2, 0.5), Vector3(0.4, 0.1, 1.0)));
  Model model = mb.build();
  ContactModelBuilder builder(model);
  builder.addGeometry("ball", BodyRef::dynamic(0), Pose::identity(), Shape::sphere(0.3));
  builder.addGeometry("pusher", BodyRef::driven(0), Pose::identity(),
                      Shape::box(Vector3(2.0, 2.0, 0.4)));
  Scene s{model, builder.build(), model.neutralConfiguration()};
  test::placeBody(model, s.q, 0, Vector3(0.1, 0.2, 0.05), Quaternion::Identity());
  for (const VectorX& v : {VectorX(VectorX::Zero(model.nv)), randomVelocity(model.nv, 9)})
    expectRatesMatch(s, v, 0.2, 0.3, 1);
}

}  // namespace
}  // namespace sweep
