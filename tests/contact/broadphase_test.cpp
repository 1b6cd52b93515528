// The grid broadphase of the analytic path and FCL's dynamic AABB tree find the same
// candidate contacts on dense random packings.
#include <gtest/gtest.h>

#include <algorithm>

#include "contact_test_scenes.hpp"

namespace sweep {
namespace {

// Polydisperse balls on a jittered lattice with spacing close to one diameter: most
// neighbours are within the margin, some overlap.
test::ShapeScene randomPacking(int count, bool planar, std::mt19937& rng) {
  std::uniform_real_distribution<double> radius(0.8, 1.2);
  std::vector<Shape> shapes;
  for (int i = 0; i < count; ++i)
    shapes.push_back(planar ? Shape::disk(radius(rng)) : Shape::sphere(radius(rng)));
  return test::shapeScene(shapes);
}

void expectSamePairs(int count, bool planar) {
  std::mt19937 rng(2024);
  const test::ShapeScene scene = randomPacking(count, planar, rng);
  const ContactModel grid = scene.contactModel(DetectionPathChoice::Automatic);
  const ContactModel tree = scene.contactModel(DetectionPathChoice::Fcl);
  ASSERT_EQ(grid.path, DetectionPath::Analytic);
  const int side = planar ? static_cast<int>(std::ceil(std::sqrt(count)))
                          : static_cast<int>(std::ceil(std::cbrt(count)));
  std::uniform_real_distribution<double> jitter(-0.15, 0.15);
  VectorX q = scene.model.neutralConfiguration();
  for (int i = 0; i < count; ++i) {
    const Vector3 cell(i % side, (i / side) % side, planar ? 0 : i / (side * side));
    const Quaternion orientation = test::randomOrientation(rng, planar);
    const Vector3 position = 2.1 * cell + test::drawVector3(rng, jitter, planar);
    test::placeBody(scene.model, q, i, position, orientation);
  }
  Data data(scene.model);
  forwardKinematics(scene.model, data, q);
  ContactData cd_grid(scene.model, grid), cd_tree(scene.model, tree);
  const double margin = 0.2;
  detectContacts(scene.model, data, grid, cd_grid, 0.0, margin);
  detectContacts(scene.model, data, tree, cd_tree, 0.0, margin);

  ASSERT_EQ(cd_grid.contacts.size(), cd_tree.contacts.size());
  // lattice neighbours at 2.1 +- 0.3 with radii 0.8-1.2: plenty of pairs inside the margin
  EXPECT_GT(cd_grid.contacts.size(), static_cast<std::size_t>(count / 2));
  int overlapping = 0;
  for (std::size_t k = 0; k < cd_grid.contacts.size(); ++k) {
    const Contact& a = cd_grid.contacts[k];
    const Contact& b = cd_tree.contacts[k];
    ASSERT_EQ(a.key, b.key) << "contact " << k;
    EXPECT_NEAR(a.gap, b.gap, 1e-9);
    overlapping += a.gap < 0.0 ? 1 : 0;
  }
  EXPECT_GT(overlapping, 0);
}

TEST(Broadphase, GridAndFclAgreeOn2000Disks) {
  expectSamePairs(2000, true);
}
TEST(Broadphase, GridAndFclAgreeOn2000Spheres) {
  expectSamePairs(2000, false);
}

// Walls, planes and a driven blade against particles: the grid's queries for large shapes
// find what FCL finds.
TEST(Broadphase, LargeShapesAgainstParticles) {
  std::mt19937 rng(5);
  const int count = 300;
  ModelBuilder builder("particles and walls");
  for (int i = 0; i < count; ++i)
    addFreeBody(builder, "p" + std::to_string(i), solidSphereInertia(1.0, 0.5));
  builder.addDrivenBody(
      DrivenBody::constantTwist("blade", Pose::identity(), Vector3(1, 0, 0), Vector3::Zero()));
  const Model model = builder.build();
  auto contactModel = [&](DetectionPathChoice path) {
    ContactModelBuilder cb(model);
    DetectionSettings settings;
    settings.path = path;
    cb.setSettings(settings);
    std::uniform_real_distribution<double> radius(0.4, 0.6);
    for (int i = 0; i < count; ++i)
      cb.addGeometry("p" + std::to_string(i), BodyRef::dynamic(i), Pose::identity(),
                     Shape::sphere(radius(rng)));
    cb.addGeometry("floor", BodyRef::world(), Pose::identity(), Shape::halfSpace());
    Pose wall;
    wall.translation = Vector3(5.0, 5.0, 5.0);
    cb.addGeometry("wall", BodyRef::world(), wall, Shape::box(Vector3(0.5, 10.0, 10.0)));
    Pose blade;
    blade.translation = Vector3(2.0, 5.0, 1.0);
    cb.addGeometry("blade", BodyRef::driven(0), blade, Shape::box(Vector3(0.2, 10.0, 1.0)));
    rng.seed(5);
    return cb.build();
  };
  const ContactModel grid = contactModel(DetectionPathChoice::Automatic);
  const ContactModel tree = contactModel(DetectionPathChoice::Fcl);
  ASSERT_EQ(grid.path, DetectionPath::Analytic) << grid.path_reason;
  std::uniform_real_distribution<double> position(0.0, 10.0), height(0.3, 3.0);
  VectorX q = model.neutralConfiguration();
  for (int i = 0; i < count; ++i) {
    const double z = height(rng), y = position(rng), x = position(rng);  // GCC's order
    test::placeBody(model, q, i, Vector3(x, y, z), Quaternion::Identity());
  }
  Data data(model);
  forwardKinematics(model, data, q);
  ContactData cd_grid(model, grid), cd_tree(model, tree);
  for (double t : {0.0, 1.5, 2.7}) {
    detectContacts(model, data, grid, cd_grid, t, 0.1);
    detectContacts(model, data, tree, cd_tree, t, 0.1);
    ASSERT_EQ(cd_grid.contacts.size(), cd_tree.contacts.size()) << "t = " << t;
    int walls = 0;
    for (std::size_t k = 0; k < cd_grid.contacts.size(); ++k) {
      EXPECT_EQ(cd_grid.contacts[k].key, cd_tree.contacts[k].key);
      EXPECT_NEAR(cd_grid.contacts[k].gap, cd_tree.contacts[k].gap, 1e-9);
      walls += cd_grid.contacts[k].key.geometry_b >= count ? 1 : 0;
    }
    EXPECT_GT(walls, 3) << "t = " << t;
  }
}

// A floor slab declared first is geometry 0, and its run of pairs holds every sphere resting
// on it (hundreds, found in the grid's cell order): the run is sorted by std::sort instead of
// insertion sort. The contacts still come out in key order, and the grid and FCL find the same
// ones.
TEST(Broadphase, AFloorUnderHundredsOfSpheresKeepsKeyOrder) {
  std::mt19937 rng(11);
  const int count = 400;
  ModelBuilder builder("spheres on a floor");
  for (int i = 0; i < count; ++i)
    addFreeBody(builder, "p" + std::to_string(i), solidSphereInertia(1.0, 0.5));
  const Model model = builder.build();
  auto contactModel = [&](DetectionPathChoice path) {
    ContactModelBuilder cb(model);
    DetectionSettings settings;
    settings.path = path;
    cb.setSettings(settings);
    // a box, not a half-space: the grid finds the grains under a box in cell order
    Pose slab;
    slab.translation = Vector3(10.5, 10.5, -0.5);
    cb.addGeometry("floor", BodyRef::world(), slab, Shape::box(Vector3(30.0, 30.0, 1.0)));
    for (int i = 0; i < count; ++i)
      cb.addGeometry("p" + std::to_string(i), BodyRef::dynamic(i), Pose::identity(),
                     Shape::sphere(0.5));
    return cb.build();
  };
  const ContactModel grid = contactModel(DetectionPathChoice::Automatic);
  const ContactModel tree = contactModel(DetectionPathChoice::Fcl);
  ASSERT_EQ(grid.path, DetectionPath::Analytic) << grid.path_reason;
  // one layer on a 20 x 20 lattice, shuffled so that the pairs arrive out of order
  std::vector<int> slot(count);
  for (int i = 0; i < count; ++i) slot[i] = i;
  std::shuffle(slot.begin(), slot.end(), rng);
  std::uniform_real_distribution<double> lift(-0.01, 0.05);
  VectorX q = model.neutralConfiguration();
  for (int i = 0; i < count; ++i)
    test::placeBody(model, q, i,
                    Vector3(1.1 * (slot[i] % 20), 1.1 * (slot[i] / 20), 0.5 + lift(rng)),
                    Quaternion::Identity());
  Data data(model);
  forwardKinematics(model, data, q);
  ContactData cd_grid(model, grid), cd_tree(model, tree);
  detectContacts(model, data, grid, cd_grid, 0.0, 0.1);
  detectContacts(model, data, tree, cd_tree, 0.0, 0.1);
  ASSERT_EQ(cd_grid.contacts.size(), cd_tree.contacts.size());
  int on_floor = 0;
  for (std::size_t k = 0; k < cd_grid.contacts.size(); ++k) {
    EXPECT_EQ(cd_grid.contacts[k].key, cd_tree.contacts[k].key) << "contact " << k;
    if (k > 0) {
      EXPECT_TRUE(cd_grid.contacts[k - 1].key < cd_grid.contacts[k].key) << k;
    }
    on_floor += cd_grid.contacts[k].key.geometry_a == 0 ? 1 : 0;
  }
  EXPECT_EQ(on_floor, count);
}

}  // namespace
}  // namespace sweep
