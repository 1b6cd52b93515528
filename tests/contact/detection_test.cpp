// Detection: persistent frames and identities, margins, materials, path choice.
#include "contact/detection.hpp"

#include <gtest/gtest.h>

#include <algorithm>

#include "contact_test_scenes.hpp"
#include "framework/configuration.hpp"
#include "framework/error.hpp"

namespace sweep {
namespace {

// `count` free balls of unit mass without gravity
Model freeBalls(int count) {
  ModelBuilder builder("lattice");
  for (int i = 0; i < count; ++i)
    addFreeBody(builder, "ball" + std::to_string(i), solidSphereInertia(1.0, 0.5));
  builder.setGravity(Vector3::Zero());
  return builder.build();
}
// their contact geometries, ball i of radius 0.5 + 0.01 (i % radius_cycle), then a floor and a
// wall box at wall_centre
void addBallsFloorAndWall(ContactModelBuilder& contacts, int count, int radius_cycle,
                          const Vector3& wall_centre, const Vector3& wall_size) {
  for (int i = 0; i < count; ++i)
    contacts.addGeometry("ball" + std::to_string(i), BodyRef::dynamic(i), Pose::identity(),
                         Shape::sphere(0.5 + 0.01 * (i % radius_cycle)));
  contacts.addGeometry("floor", BodyRef::world(), Pose::identity(), Shape::halfSpace());
  Pose wall = Pose::identity();
  wall.translation = wall_centre;
  contacts.addGeometry("wall", BodyRef::world(), wall, Shape::box(wall_size));
}

// A sphere rolling without slip on a plane for a full turn: one contact, same identity every
// step, and a tangent frame that never flips.
TEST(ContactFrames, PersistentForASphereRollingOnAPlane) {
  ModelBuilder mb("rolling");
  addFreeBody(mb, "ball", solidSphereInertia(1.0, 0.5));
  const Model model = mb.build();
  ContactModelBuilder cb(model);
  cb.addGeometry("ball", BodyRef::dynamic(0), Pose::identity(), Shape::sphere(0.5));
  Pose floor;
  floor.rotation = Eigen::AngleAxisd(0.2, Vector3(1, 1, 0).normalized()).toRotationMatrix();
  cb.addGeometry("floor", BodyRef::world(), floor, Shape::halfSpace());
  const ContactModel cmodel = cb.build();
  const Vector3 up = floor.rotation.col(2);
  VectorX q = model.neutralConfiguration();
  q.head<3>() = 0.5 * up;
  // rolling along a direction of the plane: v = w x (r up); body-frame angular velocity
  const Vector3 along = floor.rotation.col(0);
  Data data(model);
  ContactData cdata(model, cmodel);
  Vector3 previous_tangent = Vector3::Zero();
  const double h = 0.01;
  for (int step = 0; step < 700; ++step) {
    forwardKinematics(model, data, q);
    detectContacts(model, data, cmodel, cdata, 0.0, 1e-3);
    ASSERT_EQ(cdata.contacts.size(), 1u) << "step " << step;
    const Contact& c = cdata.contacts[0];
    if (step > 0) {
      EXPECT_EQ(c.previous, 0);
      EXPECT_GT(c.tangent1.dot(previous_tangent), 1.0 - 1e-12) << "step " << step;
    }
    EXPECT_NEAR(c.tangent1.dot(c.normal), 0.0, 1e-15);
    EXPECT_NEAR(c.tangent2.dot(c.normal), 0.0, 1e-15);
    EXPECT_NEAR(c.normal.cross(c.tangent1).dot(c.tangent2), 1.0, 1e-15);
    previous_tangent = c.tangent1;
    // roll: linear velocity in world, angular velocity in body axes
    const Vector3 w_world = up.cross(along) * (-1.0 / 0.5);
    VectorX v = VectorX::Zero(model.nv);
    v.head<3>() = along;
    v.tail<3>() = data.world_pose[0].rotation.transpose() * w_world;
    q = integrate(model, q, h * v);
  }
}

// A ball orbiting another over the whole sphere of directions: the normal passes through
// every axis, and the tangent carried from step to step still never flips.
TEST(ContactFrames, PersistentForABallOrbitingABall) {
  const test::ShapeScene scene = test::shapeScene({Shape::sphere(1.0), Shape::sphere(0.5)});
  const ContactModel cmodel = scene.contactModel(DetectionPathChoice::Automatic);
  Data data(scene.model);
  ContactData cdata(scene.model, cmodel);
  VectorX q = scene.model.neutralConfiguration();
  Vector3 previous_tangent = Vector3::Zero();
  for (int step = 0; step < 2000; ++step) {
    const double s = 0.01 * step;
    const Vector3 direction(std::cos(s) * std::cos(0.37 * s), std::sin(s) * std::cos(0.37 * s),
                            std::sin(0.37 * s));
    test::placeBody(scene.model, q, 1, 1.5 * direction, Quaternion::Identity());
    forwardKinematics(scene.model, data, q);
    detectContacts(scene.model, data, cmodel, cdata, 0.0, 1e-3);
    ASSERT_EQ(cdata.contacts.size(), 1u);
    const Contact& c = cdata.contacts[0];
    EXPECT_LT((c.normal - direction).norm(), 1e-12);
    if (step > 0) {
      EXPECT_GT(c.tangent1.dot(previous_tangent), 0.99) << "step " << step;
    }
    previous_tangent = c.tangent1;
  }
}

TEST(ContactFrames, PlanarTangentIsNormalTurnedCounterClockwise) {
  const test::ShapeScene scene = test::shapeScene({Shape::disk(1.0), Shape::disk(0.5)});
  const ContactModel cmodel = scene.contactModel(DetectionPathChoice::Automatic);
  EXPECT_EQ(cmodel.dimension, 2);
  Data data(scene.model);
  ContactData cdata(scene.model, cmodel);
  VectorX q = scene.model.neutralConfiguration();
  test::placeBody(scene.model, q, 1, Vector3(0.9, 1.2, 0.0), Quaternion::Identity());
  forwardKinematics(scene.model, data, q);
  detectContacts(scene.model, data, cmodel, cdata, 0.0, 0.1);
  ASSERT_EQ(cdata.contacts.size(), 1u);
  const Contact& c = cdata.contacts[0];
  EXPECT_TRUE(c.normal.isApprox(Vector3(0.6, 0.8, 0.0)));
  EXPECT_TRUE(c.tangent1.isApprox(Vector3(-0.8, 0.6, 0.0)));
  EXPECT_EQ(c.tangent2, Vector3::Zero());
}

TEST(Detection, ContactLawsPerMaterialPair) {
  const test::ShapeScene scene =
      test::shapeScene({Shape::disk(1.0), Shape::disk(1.0), Shape::disk(1.0)});
  ContactModelBuilder cb(scene.model);
  const int steel = cb.materials().add("steel");
  const int rubber = cb.materials().add("rubber");
  cb.materials().setDefaultLaw({0.1, 0.2});
  cb.materials().setLaw(steel, rubber, {0.8, 0.5});
  cb.addGeometry("a", BodyRef::dynamic(0), Pose::identity(), Shape::disk(1.0), steel);
  cb.addGeometry("b", BodyRef::dynamic(1), Pose::identity(), Shape::disk(1.0), rubber);
  cb.addGeometry("c", BodyRef::dynamic(2), Pose::identity(), Shape::disk(1.0), steel);
  const ContactModel cmodel = cb.build();
  EXPECT_FALSE(cmodel.frictionless);
  VectorX q = scene.model.neutralConfiguration();
  test::placeBody(scene.model, q, 1, Vector3(2.0, 0.0, 0.0), Quaternion::Identity());
  test::placeBody(scene.model, q, 2, Vector3(1.0, 1.75, 0.0), Quaternion::Identity());
  Data data(scene.model);
  forwardKinematics(scene.model, data, q);
  ContactData cdata(scene.model, cmodel);
  detectContacts(scene.model, data, cmodel, cdata, 0.0, 0.1);
  ASSERT_EQ(cdata.contacts.size(), 3u);  // a-b touching, a-c and b-c 0.016 apart
  // steel-rubber has its own law; steel-steel falls back to the default
  EXPECT_EQ(cdata.contacts[0].friction, 0.8);  // a-b
  EXPECT_EQ(cdata.contacts[0].restitution, 0.5);
  EXPECT_EQ(cdata.contacts[1].friction, 0.1);  // a-c
  EXPECT_EQ(cdata.contacts[1].restitution, 0.2);
  EXPECT_EQ(cdata.contacts[2].friction, 0.8);  // b-c
}

TEST(Detection, FrictionlessSceneIsFlagged) {
  const test::ShapeScene scene = test::shapeScene({Shape::disk(1.0), Shape::disk(1.0)});
  EXPECT_TRUE(scene.contactModel(DetectionPathChoice::Automatic).frictionless);
}

TEST(Detection, MarginGrowsWithSpeedAndKeepsAFloor) {
  const test::ShapeScene scene = test::shapeScene({Shape::disk(0.01), Shape::disk(0.02)});
  const ContactModel cmodel = scene.contactModel(DetectionPathChoice::Automatic);
  EXPECT_DOUBLE_EQ(cmodel.margin_floor, 1e-3 * 0.01);
  Data data(scene.model);
  VectorX q = scene.model.neutralConfiguration();
  VectorX v = VectorX::Zero(scene.model.nv);
  forwardKinematics(scene.model, data, q, v);
  EXPECT_DOUBLE_EQ(detectionMargin(scene.model, data, cmodel, 1e-3, 0.0), cmodel.margin_floor);
  v.segment<3>(3) << 3.0, 4.0, 10.0;  // 5 m/s and 10 rad/s on a 0.02 m disk
  forwardKinematics(scene.model, data, q, v);
  EXPECT_NEAR(detectionMargin(scene.model, data, cmodel, 1e-3, 0.0),
              2.0 * 1e-3 * (5.0 + 10.0 * 0.02) + cmodel.margin_floor, 1e-15);
}

// The relative rule: balls that move together, whatever they spin, close no gap, so their
// pair keeps the floor; the other pairs keep the absolute margin.
TEST(Detection, RelativeBallMarginIgnoresSpinAndCommonMotion) {
  const test::ShapeScene scene = test::shapeScene({Shape::disk(0.01), Shape::disk(0.02)});
  ContactModel cmodel = scene.contactModel(DetectionPathChoice::Automatic);
  cmodel.settings.margin_rule = MarginRule::Relative;
  const double h = 1e-3;
  Data data(scene.model);
  VectorX q = scene.model.neutralConfiguration();
  q[2] = 0.7;  // turned differently: the velocities are compared in the world frame
  q[5] = -2.1;
  VectorX v(6);
  v << 1.0, 2.0, 50.0, 1.0, 2.0, -30.0;  // one velocity, opposite spins
  forwardKinematics(scene.model, data, q, v);
  EXPECT_LT(ballClosingSpeed(scene.model, data, cmodel, 0.0), 1e-15);
  DetectionMargins margins = detectionMargins(scene.model, data, cmodel, h, 0.0);
  EXPECT_NEAR(margins.balls, cmodel.margin_floor, 1e-17);
  EXPECT_DOUBLE_EQ(margins.others, detectionMargin(scene.model, data, cmodel, h, 0.0));
  EXPECT_GT(margins.others, 2.0 * h * 30.0 * 0.02);
  // (1, 2) and (3, 2) about their middle (2, 2): 1 m/s, below the fastest centre's 3.6 m/s
  v << 1.0, 2.0, 50.0, 3.0, 2.0, 0.0;
  forwardKinematics(scene.model, data, q, v);
  EXPECT_NEAR(ballClosingSpeed(scene.model, data, cmodel, 0.0), 1.0, 1e-15);
  margins = detectionMargins(scene.model, data, cmodel, h, 0.0);
  EXPECT_NEAR(margins.balls, 2.0 * h * 1.0 + cmodel.margin_floor, 1e-15);
  // the absolute rule: one margin for every pair, as before
  cmodel.settings.margin_rule = MarginRule::Absolute;
  margins = detectionMargins(scene.model, data, cmodel, h, 0.0);
  EXPECT_EQ(margins.balls, margins.others);
  EXPECT_EQ(margins.others, detectionMargin(scene.model, data, cmodel, h, 0.0));
}

// A driven body's fastest shape point: |v_origin| + |w| * reach, which bounds the speed of each
// of its shape's corners and is what fastestShapeSpeed counts for it when the free bodies rest.
TEST(Detection, FastestDrivenShapeSpeedBoundsTheDrivenShapesPoints) {
  ModelBuilder mb("driven");
  addFreeBody(mb, "ball", solidSphereInertia(1.0, 0.3));
  Pose start;
  start.translation = Vector3(0.0, 0.0, -0.5);
  const Vector3 linear(0.3, -0.2, 0.5), angular(0.4, 0.1, 1.0);
  mb.addDrivenBody(DrivenBody::constantTwist("pusher", start, linear, angular));
  const Model model = mb.build();
  ContactModelBuilder builder(model);
  builder.addGeometry("ball", BodyRef::dynamic(0), Pose::identity(), Shape::sphere(0.3));
  const Vector3 half(1.0, 1.0, 0.2);
  Pose offset;
  offset.translation = Vector3(0.5, 0.0, 0.0);
  builder.addGeometry("pusher", BodyRef::driven(0), offset, Shape::box(2.0 * half));
  const ContactModel cmodel = builder.build();
  const double t = 0.3;
  const double fastest = fastestDrivenShapeSpeed(model, cmodel, t);
  const DrivenBody& pusher = model.driven_bodies[0];
  double corner_fastest = 0.0;
  for (int corner = 0; corner < 8; ++corner) {
    const Vector3 local(corner & 1 ? half.x() : -half.x(), corner & 2 ? half.y() : -half.y(),
                        corner & 4 ? half.z() : -half.z());
    const Vector3 world = pusher.pose(t).apply(offset.apply(local));
    corner_fastest = std::max(corner_fastest, pusher.pointVelocity(world, t).norm());
  }
  EXPECT_GE(fastest, corner_fastest);
  EXPECT_GT(fastest, linear.norm());
  Data data(model);
  forwardKinematics(model, data, model.neutralConfiguration(), VectorX::Zero(model.nv));
  EXPECT_DOUBLE_EQ(fastest, fastestShapeSpeed(model, data, cmodel, t));
  // without driven bodies, nothing
  ModelBuilder alone_builder("alone");
  addFreeBody(alone_builder, "ball", solidSphereInertia(1.0, 0.3));
  const Model alone = alone_builder.build();
  ContactModelBuilder alone_contacts(alone);
  alone_contacts.addGeometry("ball", BodyRef::dynamic(0), Pose::identity(), Shape::sphere(0.3));
  EXPECT_EQ(fastestDrivenShapeSpeed(alone, alone_contacts.build(), t), 0.0);
}

// In 3D the centres' velocities are compared in the world frame: two spheres turned
// differently, with one world velocity and different spins, close on nothing.
TEST(Detection, RelativeBallMarginComparesWorldVelocities) {
  const test::ShapeScene scene = test::shapeScene({Shape::sphere(0.01), Shape::sphere(0.02)});
  ContactModel cmodel = scene.contactModel(DetectionPathChoice::Automatic);
  cmodel.settings.margin_rule = MarginRule::Relative;
  std::mt19937 rng(7);
  VectorX q = scene.model.neutralConfiguration();
  test::placeBody(scene.model, q, 0, Vector3(0, 0, 0), test::randomOrientation(rng, false));
  test::placeBody(scene.model, q, 1, Vector3(1, 0, 0), test::randomOrientation(rng, false));
  VectorX v(12);  // per body: linear velocity (parent frame), angular velocity (body axes)
  v << 1.0, 2.0, 3.0, 40.0, -5.0, 6.0, 1.0, 2.0, 3.0, -7.0, 80.0, 9.0;
  Data data(scene.model);
  forwardKinematics(scene.model, data, q, v);
  EXPECT_LT(ballClosingSpeed(scene.model, data, cmodel, 0.0), 1e-14);
  v.segment<3>(6) << 1.0, 2.0, 5.0;  // 2 m/s apart along z: 1 m/s about the middle
  forwardKinematics(scene.model, data, q, v);
  EXPECT_NEAR(ballClosingSpeed(scene.model, data, cmodel, 0.0), 1.0, 1e-14);
}

// Pairs of two balls take the balls' margin, every other pair the other one.
TEST(Detection, EachPairTakesItsOwnMargin) {
  const test::ShapeScene scene = test::shapeScene(
      {Shape::sphere(1.0), Shape::sphere(1.0), Shape::box(Vector3(2.0, 2.0, 2.0))});
  for (DetectionPathChoice path : {DetectionPathChoice::Analytic, DetectionPathChoice::Fcl}) {
    const ContactModel cmodel = scene.contactModel(path);
    VectorX q = scene.model.neutralConfiguration();
    test::placeBody(scene.model, q, 1, Vector3(2.05, 0.0, 0.0), Quaternion::Identity());
    test::placeBody(scene.model, q, 2, Vector3(0.0, -2.05, 0.0), Quaternion::Identity());
    Data data(scene.model);
    forwardKinematics(scene.model, data, q);
    ContactData cdata(scene.model, cmodel);
    auto pairs = [&](const DetectionMargins& margins) {
      detectContacts(scene.model, data, cmodel, cdata, 0.0, margins);
      std::vector<std::pair<int, int>> out;
      for (const Contact& c : cdata.contacts) out.emplace_back(c.key.geometry_a, c.key.geometry_b);
      return out;
    };
    using Pairs = std::vector<std::pair<int, int>>;
    // both gaps are 0.05; the second sphere is 0.48 from the box
    EXPECT_EQ(pairs({0.01, 0.1}), (Pairs{{0, 2}})) << detectionPathName(cmodel.path);
    EXPECT_EQ(pairs({0.1, 0.01}), (Pairs{{0, 1}})) << detectionPathName(cmodel.path);
    EXPECT_EQ(pairs({0.1, 0.1}), (Pairs{{0, 1}, {0, 2}})) << detectionPathName(cmodel.path);
  }
}

TEST(Detection, RelativeMarginNeedsTheCheck) {
  DetectionSettings settings;
  settings.margin_rule = MarginRule::Relative;
  EXPECT_NO_THROW(settings.validate());
  settings.verify_margin = false;
  EXPECT_THROW(settings.validate(), InputError);
}

TEST(Detection, PathChoiceIsExplained) {
  const test::ShapeScene disks = test::shapeScene({Shape::disk(1.0), Shape::disk(1.0)});
  const ContactModel fast = disks.contactModel(DetectionPathChoice::Automatic);
  EXPECT_EQ(fast.path, DetectionPath::Analytic);
  EXPECT_FALSE(fast.path_reason.empty());
  const test::ShapeScene mixed =
      test::shapeScene({Shape::disk(1.0), Shape::polygon({{0, 0}, {1, 0}, {0, 1}})});
  const ContactModel general = mixed.contactModel(DetectionPathChoice::Automatic);
  EXPECT_EQ(general.path, DetectionPath::Fcl);
  EXPECT_NE(general.path_reason.find("polygon"), std::string::npos) << general.path_reason;
  EXPECT_THROW(mixed.contactModel(DetectionPathChoice::Analytic), InputError);
  EXPECT_EQ(describe(fast),
            "contact: 2 shapes (2D), detection analytic narrowphase + uniform grid (every pair "
            "that can meet has a closed form), margin floor 0.001 m, friction off (every mu = 0)");
}

// Same configuration twice: bitwise the same contacts, in the same order.
TEST(Detection, Deterministic) {
  std::vector<Shape> shapes;
  for (int i = 0; i < 200; ++i) shapes.push_back(Shape::sphere(0.5 + 0.001 * i));
  const test::ShapeScene scene = test::shapeScene(shapes);
  for (DetectionPathChoice path : {DetectionPathChoice::Automatic, DetectionPathChoice::Fcl}) {
    const ContactModel cmodel = scene.contactModel(path);
    std::mt19937 rng(1);
    std::uniform_real_distribution<double> u(0.0, 6.0);
    VectorX q = scene.model.neutralConfiguration();
    for (int i = 0; i < 200; ++i)
      test::placeBody(scene.model, q, i, test::drawVector3(rng, u), Quaternion::Identity());
    Data data(scene.model);
    forwardKinematics(scene.model, data, q);
    ContactData first(scene.model, cmodel), second(scene.model, cmodel);
    detectContacts(scene.model, data, cmodel, first, 0.0, 0.05);
    detectContacts(scene.model, data, cmodel, second, 0.0, 0.05);
    ASSERT_EQ(first.contacts.size(), second.contacts.size());
    ASSERT_GT(first.contacts.size(), 10u);
    for (std::size_t k = 0; k < first.contacts.size(); ++k) {
      EXPECT_EQ(first.contacts[k].key, second.contacts[k].key);
      EXPECT_EQ(first.contacts[k].gap, second.contacts[k].gap);
      EXPECT_EQ(first.contacts[k].normal, second.contacts[k].normal);
    }
  }
}

// A blade spanning a bed meets the grains along its face: the broadphase queries the grid with
// the blade's box along the world axes, not with its bounding ball's cube, which held every
// grain of the bed (a powder bed's blade, gate and fence: three runs of every grain a step).
TEST(Detection, ALongBoxMeetsOnlyTheGrainsNearItsFace) {
  ModelBuilder builder("bed");
  const int nx = 20, ny = 5, nz = 40, count = nx * ny * nz;
  for (int i = 0; i < count; ++i)
    addFreeBody(builder, "ball" + std::to_string(i), solidSphereInertia(1.0, 0.4));
  builder.setGravity(Vector3::Zero());
  const Model model = builder.build();
  VectorX q = model.neutralConfiguration();
  for (int i = 0; i < count; ++i)
    test::placeBody(model, q, i, Vector3(i % nx, (i / nx) % ny, i / (nx * ny)),
                    Quaternion::Identity());
  auto detect = [&](bool with_blade, int threads) {
    ContactModelBuilder contacts(model);
    for (int i = 0; i < count; ++i)
      contacts.addGeometry("ball" + std::to_string(i), BodyRef::dynamic(i), Pose::identity(),
                           Shape::sphere(0.4));
    if (with_blade) {
      // 0.01 from the first column's grains, turned a little about x
      Pose blade = Pose::identity();
      blade.translation = Vector3(-0.41 - 0.1, 2.0, 19.5);
      blade.rotation = Matrix3(Eigen::AngleAxisd(1e-4, Vector3::UnitX()));
      contacts.addGeometry("blade", BodyRef::world(), blade, Shape::box(Vector3(0.2, 6.0, 42.0)));
    }
    const ContactModel cmodel = contacts.build();
    EXPECT_EQ(cmodel.path, DetectionPath::Analytic);
    ContactData cdata(model, cmodel);
    Data data(model);
    data.threads = threads;
    forwardKinematics(model, data, q);
    detectContacts(model, data, cmodel, cdata, 0.0, DetectionMargins::uniform(0.02), threads);
    return cdata;
  };
  const ContactData bare = detect(false, 1);
  for (int threads : {1, 2}) {
    const ContactData bed = detect(true, threads);
    int blade_contacts = 0;
    for (const Contact& c : bed.contacts) blade_contacts += c.key.geometry_b == count ? 1 : 0;
    EXPECT_EQ(blade_contacts, ny * nz) << threads;  // the first column, every grain of it
    // the blade's pairs: the grains of the grid cells its box reaches, at most two columns of
    // them, not the bed's 4 000
    EXPECT_LE(bed.stats.broadphase_pairs - bare.stats.broadphase_pairs, 2 * ny * nz) << threads;
  }
}

// The grid path on threads (broadphase, pair sort, narrowphase, matching): the same list, bit
// for bit, for 1 to 4 threads. 12 000 balls on a jittered lattice (over 8192 pairs: the
// threaded path) above a floor and beside a wall (runs of thousands of pairs), detected
// twice, the second time moved, so that contacts are matched to the first detection's.
TEST(Detection, ThreadsGiveTheSameContacts) {
  const int count = 12000;
  const Model model = freeBalls(count);
  ContactModelBuilder contacts(model);
  addBallsFloorAndWall(contacts, count, 7, Vector3(-0.4, 10.0, 5.0), Vector3(0.2, 30.0, 30.0));
  const ContactModel cmodel = contacts.build();
  ASSERT_EQ(cmodel.path, DetectionPath::Analytic);

  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-0.06, 0.06);
  VectorX q = model.neutralConfiguration();
  for (int i = 0; i < count; ++i) {
    const Vector3 site(i % 20, (i / 20) % 30, 0.45 + i / 600);
    test::placeBody(model, q, i, site + Vector3(jitter(rng), jitter(rng), jitter(rng)),
                    Quaternion::Identity());
  }
  VectorX moved = q;
  for (int i = 0; i < count; ++i)
    moved.segment<3>(model.bodies[i].q_index) += Vector3(jitter(rng), jitter(rng), jitter(rng));

  auto detectTwice = [&](int threads) {
    ContactData cdata(model, cmodel);
    Data data(model);
    data.threads = threads;
    for (const VectorX* at : {&q, &moved}) {
      forwardKinematics(model, data, *at);
      detectContacts(model, data, cmodel, cdata, 0.0, DetectionMargins::uniform(0.02), threads);
    }
    return cdata;
  };
  const ContactData one = detectTwice(1);
  ASSERT_GT(one.stats.broadphase_pairs, 8192);
  ASSERT_GT(one.stats.matched, 1000);
  int floor_contacts = 0, wall_contacts = 0;
  for (const Contact& c : one.contacts) {
    floor_contacts += c.key.geometry_b == count ? 1 : 0;
    wall_contacts += c.key.geometry_b == count + 1 ? 1 : 0;
  }
  // every ball within the margin of the floor, and only those (the broadphase culls the
  // floor's pairs by their gaps before the narrowphase)
  Data at_moved(model);
  forwardKinematics(model, at_moved, moved);
  int near_floor = 0;
  for (int i = 0; i < count; ++i)
    near_floor += at_moved.world_pose[i].translation.z() - cmodel.traits[i].ball_radius < 0.02;
  EXPECT_EQ(floor_contacts, near_floor);
  ASSERT_GT(floor_contacts, 100);
  ASSERT_GT(wall_contacts, 100);
  for (int threads : {2, 3, 4}) {
    const ContactData other = detectTwice(threads);
    EXPECT_EQ(other.stats.broadphase_pairs, one.stats.broadphase_pairs) << threads;
    EXPECT_EQ(other.stats.matched, one.stats.matched) << threads;
    ASSERT_EQ(other.contacts.size(), one.contacts.size()) << threads;
    for (std::size_t k = 0; k < one.contacts.size(); ++k) {
      const Contact &a = one.contacts[k], &b = other.contacts[k];
      ASSERT_EQ(a.key, b.key) << threads << " threads, contact " << k;
      ASSERT_EQ(a.previous, b.previous) << threads << " threads, contact " << k;
      ASSERT_EQ(a.gap, b.gap) << threads << " threads, contact " << k;
      ASSERT_EQ(a.normal, b.normal) << threads << " threads, contact " << k;
      ASSERT_EQ(a.tangent1, b.tangent1) << threads << " threads, contact " << k;
      ASSERT_EQ(a.point_b, b.point_b) << threads << " threads, contact " << k;
    }
  }
}

// A rank of a distributed run bins its own and its ghost grains and keeps the pairs whose
// lowest owner rank is its own (restrictParticles with body_rank): three ranks, cut along x,
// a periodic axis along y, a floor and a wall. Together the ranks find every contact of the
// whole scene once, each on the rank that owns it, with the same gaps.
TEST(Detection, RanksKeepThePairsTheyOwnAndTogetherFindEveryOne) {
  const int nx = 24, ny = 10, nz = 4, count = nx * ny * nz;
  const Model model = freeBalls(count);
  ContactModelBuilder contacts(model);
  addBallsFloorAndWall(contacts, count, 5, Vector3(-0.45, 5.0, 2.0), Vector3(0.2, 12.0, 6.0));
  DetectionSettings settings;
  settings.periodic.axis = 1;
  settings.periodic.low = -0.5;
  settings.periodic.high = ny - 0.5;
  contacts.setSettings(settings);
  const ContactModel cmodel = contacts.build();
  ASSERT_EQ(cmodel.path, DetectionPath::Analytic);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> jitter(-0.05, 0.05);
  VectorX q = model.neutralConfiguration();
  for (int i = 0; i < count; ++i)
    test::placeBody(model, q, i,
                    Vector3(i % nx, (i / nx) % ny, 0.5 + i / (nx * ny)) +
                        Vector3(jitter(rng), jitter(rng), jitter(rng)),
                    Quaternion::Identity());
  Data data(model);
  forwardKinematics(model, data, q);
  const DetectionMargins margins = DetectionMargins::uniform(0.05);
  ContactData whole(model, cmodel);
  detectContacts(model, data, cmodel, whole, 0.0, margins);
  ASSERT_GT(whole.contacts.size(), 2u * count);

  const int ranks = 3;
  auto rankAt = [&](double x) { return std::clamp(static_cast<int>(x / (nx / ranks)), 0, 2); };
  std::vector<int> body_rank(count);
  for (int i = 0; i < count; ++i) body_rank[i] = rankAt(q[model.bodies[i].q_index]);
  std::vector<std::pair<ContactKey, double>> found;
  for (int rank = 0; rank < ranks; ++rank) {
    // owned, and the ghosts within two diameters of the rank's slab
    std::vector<char> local(count, 0);
    for (int i = 0; i < count; ++i) {
      const double x = q[model.bodies[i].q_index];
      local[i] = rankAt(x - 2.2) <= rank && rankAt(x + 2.2) >= rank;
    }
    ContactData mine(model, cmodel);
    restrictParticles(cmodel, local, mine, &body_rank, rank);
    detectContacts(model, data, cmodel, mine, 0.0, margins);
    for (const Contact& contact : mine.contacts) {
      int lowest = ranks;
      for (const BodyRef* body : {&contact.body_a, &contact.body_b})
        if (body->kind == BodyRef::Kind::Dynamic) lowest = std::min(lowest, body_rank[body->index]);
      EXPECT_EQ(lowest, rank);
      found.emplace_back(contact.key, contact.gap);
    }
  }
  std::sort(found.begin(), found.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  ASSERT_EQ(found.size(), whole.contacts.size());
  for (std::size_t k = 0; k < found.size(); ++k) {
    EXPECT_EQ(found[k].first, whole.contacts[k].key);
    EXPECT_EQ(found[k].second, whole.contacts[k].gap);
  }
}

}  // namespace
}  // namespace sweep
