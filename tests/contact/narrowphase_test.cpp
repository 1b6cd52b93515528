// The closed forms of the analytic path against FCL, on randomized configurations.
#include "contact/narrowphase_analytic.hpp"
#include "contact/narrowphase_mesh.hpp"

#include <random>

#include "contact/mesh_io.hpp"

#include <fcl/fcl.h>
#include <gtest/gtest.h>

#include "contact_test_scenes.hpp"

namespace sweep {
namespace {

using test::ShapeScene;

struct PairCase {
  const char* name;
  Shape container;  // body 0
  Shape ball;       // body 1
};

class AnalyticVsFcl : public ::testing::TestWithParam<PairCase> {};

// Same gap, normal and witness points from the analytic path and the FCL path on separated,
// touching and overlapping configurations. The tolerance, 1e-9 of the pair's size, is what
// double precision leaves of closed forms evaluated in different orders.
TEST_P(AnalyticVsFcl, SameContacts) {
  const PairCase& pc = GetParam();
  const ShapeScene scene = test::shapeScene({pc.container, pc.ball});
  const ContactModel analytic = scene.contactModel(DetectionPathChoice::Analytic);
  const ContactModel general = scene.contactModel(DetectionPathChoice::Fcl);
  ASSERT_EQ(analytic.path, DetectionPath::Analytic);
  ASSERT_EQ(general.path, DetectionPath::Fcl);
  Data data(scene.model);
  ContactData cd_analytic(scene.model, analytic), cd_general(scene.model, general);
  const bool planar = isPlanarShape(pc.ball.type);
  const double size = boundingRadius(pc.container) + pc.ball.radius;
  const double tol = 1e-9 * size;
  const double margin = 0.5 * size;

  std::mt19937 rng(42);
  std::uniform_real_distribution<double> box(-1.2 * size, 1.2 * size);
  int separated = 0, touching = 0, overlapping = 0;
  VectorX q = scene.model.neutralConfiguration();
  for (int trial = 0; trial < 3000; ++trial) {
    const Quaternion orientation = test::randomOrientation(rng, planar);
    test::placeBody(scene.model, q, 0, test::drawVector3(rng, box, planar), orientation);
    Vector3 center = test::drawVector3(rng, box, planar);
    test::placeBody(scene.model, q, 1, center, Quaternion::Identity());
    forwardKinematics(scene.model, data, q);
    detectContacts(scene.model, data, analytic, cd_analytic, 0.0, margin);
    if (trial % 3 == 0 && cd_analytic.contacts.size() == 1) {
      // slide the ball along the normal to exact contact
      const Contact& c = cd_analytic.contacts[0];
      center += (c.key.geometry_a == 1 ? 1.0 : -1.0) * c.gap * c.normal;
      test::placeBody(scene.model, q, 1, center, Quaternion::Identity());
      forwardKinematics(scene.model, data, q);
      detectContacts(scene.model, data, analytic, cd_analytic, 0.0, margin);
    }
    detectContacts(scene.model, data, general, cd_general, 0.0, margin);
    ASSERT_EQ(cd_analytic.contacts.size(), cd_general.contacts.size()) << "trial " << trial;
    if (cd_analytic.contacts.empty()) continue;
    const Contact& a = cd_analytic.contacts[0];
    const Contact& f = cd_general.contacts[0];
    EXPECT_NEAR(a.gap, f.gap, tol) << "trial " << trial;
    EXPECT_LT((a.normal - f.normal).norm(), 1e-9)
        << "trial " << trial << " gap " << a.gap << " " << f.gap << " n " << a.normal.transpose()
        << " / " << f.normal.transpose() << " pa " << a.point_a.transpose() << " / "
        << f.point_a.transpose() << " pb " << a.point_b.transpose() << " / "
        << f.point_b.transpose();
    EXPECT_NEAR((a.point_b - a.point_a - a.gap * a.normal).norm(), 0.0, tol);
    if (a.gap > tol) {
      ++separated;
      EXPECT_LT((a.point_a - f.point_a).norm(), tol) << "trial " << trial;
      EXPECT_LT((a.point_b - f.point_b).norm(), tol) << "trial " << trial;
    } else {
      (a.gap < -tol ? overlapping : touching) += 1;
      // FCL reports one point per overlap, placed differently for each pair type; it must
      // lie on the line through Sweep's witness points
      const Vector3 fcl_point = 0.5 * (f.point_a + f.point_b);
      const Vector3 off = fcl_point - a.point_a;
      EXPECT_LT((off - a.normal * a.normal.dot(off)).norm(), tol) << "trial " << trial;
    }
  }
  EXPECT_GT(separated, 100);
  EXPECT_GT(touching, 100);
  EXPECT_GT(overlapping, 100);
}

INSTANTIATE_TEST_SUITE_P(
    Pairs, AnalyticVsFcl,
    ::testing::Values(
        PairCase{"disk_disk", Shape::disk(0.7), Shape::disk(0.3)},
        PairCase{"disk_segment", Shape::segment({-1.0, 0.2}, {0.8, -0.1}), Shape::disk(0.3)},
        PairCase{"disk_rounded_segment", Shape::segment({-1.0, 0.2}, {0.8, -0.1}, 0.1),
                 Shape::disk(0.3)},
        PairCase{"sphere_sphere", Shape::sphere(0.7), Shape::sphere(0.3)},
        PairCase{"sphere_box", Shape::box(Vector3(1.0, 0.6, 1.6)), Shape::sphere(0.3)}),
    [](const auto& param_info) { return std::string(param_info.param.name); });

// Half-spaces are not in FCL's distance matrix (it dereferences a null support function), so
// the closed form is checked against FCL's sphere-half-space collision when overlapping and
// against the distance to a large box whose face is the plane when separated.
TEST(HalfSpaceVsFcl, BallGapNormalAndPoints) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  int separated = 0, overlapping = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const bool planar = trial % 2 == 0;  // disk against half-plane: normal in the plane
    Vector3 outward = test::drawVector3(rng, unit, planar);
    outward.normalize();
    const Vector3 origin = test::drawVector3(rng, unit, planar);
    const double radius = 0.2 + 0.3 * (unit(rng) + 1.0);
    const Vector3 center = test::drawVector3(rng, unit, planar);
    const ContactPoint c = halfSpaceBall(origin, outward, center, radius);
    const double tol = 1e-9 * radius;

    fcl::Transform3d plane_tf = fcl::Transform3d::Identity();
    plane_tf.translation() = origin;
    plane_tf.linear() =
        Eigen::Quaterniond::FromTwoVectors(Vector3::UnitZ(), outward).toRotationMatrix();
    fcl::Transform3d ball_tf = fcl::Transform3d::Identity();
    ball_tf.translation() = center;
    auto sphere = std::make_shared<fcl::Sphered>(radius);
    fcl::CollisionObjectd ball(sphere, ball_tf);
    if (c.gap < 0.0) {
      ++overlapping;
      fcl::CollisionObjectd half(std::make_shared<fcl::Halfspaced>(Vector3::UnitZ(), 0.0),
                                 plane_tf);
      fcl::CollisionRequestd request(1, true);
      fcl::CollisionResultd result;
      fcl::collide(&half, &ball, request, result);
      ASSERT_EQ(result.numContacts(), 1u);
      const fcl::Contactd& fc = result.getContact(0);
      EXPECT_NEAR(c.gap, -fc.penetration_depth, tol);
      EXPECT_LT((c.normal - fc.normal).norm(), 1e-9);
      const Vector3 off = fc.pos - c.point_a;
      EXPECT_LT((off - c.normal * c.normal.dot(off)).norm(), tol);
    } else {
      ++separated;
      const double depth = 100.0;
      fcl::Transform3d slab_tf = plane_tf;
      slab_tf.translation() -= 0.5 * depth * outward;
      fcl::CollisionObjectd slab(std::make_shared<fcl::Boxd>(depth, depth, depth), slab_tf);
      fcl::DistanceRequestd request(true);
      fcl::DistanceResultd result;
      const double d = fcl::distance(&slab, &ball, request, result);
      EXPECT_NEAR(c.gap, d, tol);
      EXPECT_LT((c.point_a - result.nearest_points[0]).norm(), tol);
      EXPECT_LT((c.point_b - result.nearest_points[1]).norm(), tol);
      if (d > tol) {
        EXPECT_LT((c.normal - (result.nearest_points[1] - result.nearest_points[0]) / d).norm(),
                  1e-9);
      }
    }
  }
  EXPECT_GT(separated, 300);
  EXPECT_GT(overlapping, 300);
}

// A block's corners against a half-space: one contact per corner below the margin, with the
// exact corner gaps.
TEST(HalfSpaceShape, BoxCornersBelowMargin) {
  const Shape box = Shape::box(Vector3(2.0, 1.0, 1.0));
  Pose pose;
  pose.rotation = Eigen::AngleAxisd(0.1, Vector3::UnitY()).toRotationMatrix();
  pose.translation = Vector3(0, 0, 0.55);
  std::vector<ContactPoint> points;
  halfSpaceShape(Vector3::Zero(), Vector3::UnitZ(), box, pose, 0.05,
                 [&](const ContactPoint& c) { points.push_back(c); });
  // the two lower corners at x = +1 are dipped by rotation about y
  ASSERT_EQ(points.size(), 2u);
  for (const ContactPoint& c : points) {
    const Vector3 corner = pose.apply(Vector3(1.0, c.feature & 2 ? 0.5 : -0.5, -0.5));
    EXPECT_NEAR(c.gap, corner.z(), 1e-15);
    EXPECT_TRUE(c.point_b.isApprox(corner));
    EXPECT_NEAR(c.point_a.z(), 0.0, 1e-15);
  }
}

}  // namespace
}  // namespace sweep

namespace sweep {
namespace {

// A square of two triangles in z = 0 (front +z), and a fold along the y axis: two squares at
// `slope` up (a valley, concave) or down (a ridge, convex) from the fold.
std::shared_ptr<const TriangleMesh> foldedSquares(double slope) {
  auto mesh = std::make_shared<TriangleMesh>();
  const double z = slope;  // height of the outer edges at x = +-1
  mesh->vertices = {{-1, -1, z}, {0, -1, 0}, {1, -1, z}, {-1, 1, z}, {0, 1, 0}, {1, 1, z}};
  mesh->triangles = {{0, 1, 4}, {0, 4, 3}, {1, 2, 5}, {1, 5, 4}};
  return Shape::triangleMesh(mesh).mesh;
}

std::vector<ContactPoint> meshBallContacts(const TriangleMesh& mesh, const Vector3& center,
                                           double radius, double margin) {
  std::vector<ContactPoint> out;
  meshBall(Pose::identity(), mesh, center, radius, margin,
           [&](const ContactPoint& c) { out.push_back(c); });
  return out;
}

// The mesh's closed form: the faces' normals, one contact per feature, none from the edges
// inside a flat or concave patch, and a ball crossing the surface pushed back to its front.
TEST(MeshBall, FacesRidgesAndValleysGiveTheirOwnContacts) {
  const auto flat = foldedSquares(0.0);
  const double r = 0.1;
  // above the diagonal of a split square and above the fold: the face only, along +z
  for (const Vector3& x :
       {Vector3(0.3, 0.2, 0.15), Vector3(0.0, 0.0, 0.15), Vector3(0.5, 0.5, 0.15)}) {
    const auto c = meshBallContacts(*flat, x, r, 0.1);
    ASSERT_EQ(c.size(), 1u) << x.transpose();
    EXPECT_NEAR(c[0].gap, 0.05, 1e-15);
    EXPECT_NEAR((c[0].normal - Vector3::UnitZ()).norm(), 0.0, 1e-15);
    EXPECT_NEAR((c[0].point_a - Vector3(x.x(), x.y(), 0.0)).norm(), 0.0, 1e-15);
  }
  // crossing the surface (centre 0.04 below it): pushed back up; far behind it: nothing
  const auto crossing = meshBallContacts(*flat, Vector3(0.3, 0.2, -0.04), r, 0.1);
  ASSERT_EQ(crossing.size(), 1u);
  EXPECT_NEAR(crossing[0].gap, -0.14, 1e-15);
  EXPECT_EQ(crossing[0].normal, Vector3::UnitZ());
  EXPECT_TRUE(meshBallContacts(*flat, Vector3(0.3, 0.2, -0.5), r, 0.1).empty());
  // past the rim: the boundary edge, pointing at the centre
  const auto rim = meshBallContacts(*flat, Vector3(1.05, 0.2, 0.05), r, 0.1);
  ASSERT_EQ(rim.size(), 1u);
  EXPECT_NEAR(rim[0].gap, std::hypot(0.05, 0.05) - r, 1e-15);
  // a ridge (the outer edges 0.5 below the fold): above the fold, the fold's edge alone
  const auto ridge = meshBallContacts(*foldedSquares(-0.5), Vector3(0.0, 0.2, 0.15), r, 0.1);
  ASSERT_EQ(ridge.size(), 1u);
  EXPECT_NEAR(ridge[0].gap, 0.05, 1e-15);
  EXPECT_NEAR((ridge[0].normal - Vector3::UnitZ()).norm(), 0.0, 1e-15);
  // a valley: both faces, each along its own normal, and not the fold between them
  const auto valley = meshBallContacts(*foldedSquares(1.0), Vector3(0.0, 0.2, 0.14), r, 0.1);
  ASSERT_EQ(valley.size(), 2u);
  for (const ContactPoint& c : valley) {
    EXPECT_NEAR(std::abs(c.normal.x()), 1.0 / std::sqrt(2.0), 1e-15);
    EXPECT_NEAR(c.gap, 0.14 / std::sqrt(2.0) - r, 1e-15);
  }
  EXPECT_LT(valley[0].normal.x() * valley[1].normal.x(), 0.0);
}

// A square pyramid: apex at the origin, base corners (+-1, +-1, -1), front outward.
std::shared_ptr<const TriangleMesh> pyramid() {
  auto mesh = std::make_shared<TriangleMesh>();
  mesh->vertices = {{0, 0, 0}, {1, 1, -1}, {-1, 1, -1}, {-1, -1, -1}, {1, -1, -1}};
  mesh->triangles = {{0, 4, 1}, {0, 1, 2}, {0, 2, 3}, {0, 3, 4}};
  return Shape::triangleMesh(mesh).mesh;
}

// A closed slab [-1, 1] x [-1, 1] x [-0.2, 0], front outward.
std::shared_ptr<const TriangleMesh> slab() {
  auto mesh = std::make_shared<TriangleMesh>();
  for (int k = 0; k < 8; ++k)
    mesh->vertices.emplace_back((k & 1) ? 1.0 : -1.0, (k & 2) ? 1.0 : -1.0, (k & 4) ? 0.0 : -0.2);
  mesh->triangles = {{4, 5, 7}, {4, 7, 6}, {0, 2, 3}, {0, 3, 1}, {0, 1, 5}, {0, 5, 4},
                     {2, 6, 7}, {2, 7, 3}, {0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}};
  return Shape::triangleMesh(mesh).mesh;
}

std::vector<ContactPoint> meshBoxContacts(const TriangleMesh& mesh, const Vector3& center,
                                          const Vector3& half_extents, double margin) {
  std::vector<ContactPoint> out;
  Pose box;
  box.translation = center;
  meshBox(Pose::identity(), mesh, box, half_extents, margin, out);
  return out;
}

// Every contact 1 cm deep along +z, at the given points in any order.
void expectUpwardAt(const std::vector<ContactPoint>& contacts, std::vector<Vector3> points) {
  ASSERT_EQ(contacts.size(), points.size());
  for (const ContactPoint& c : contacts) {
    EXPECT_NEAR(c.gap, -0.01, 1e-15);
    EXPECT_NEAR((c.normal - Vector3::UnitZ()).norm(), 0.0, 1e-14);
    EXPECT_NEAR((c.point_b - c.point_a - c.gap * c.normal).norm(), 0.0, 1e-15);
    const auto at = std::find_if(points.begin(), points.end(),
                                 [&](const Vector3& p) { return (p - c.point_a).norm() < 1e-12; });
    ASSERT_NE(at, points.end()) << c.point_a.transpose();
    points.erase(at);
  }
}

// A box 1 cm into a mesh: its four corners on a flat patch, the two edges that cross a ridge
// (and nothing from its corners over the slopes), a pyramid's apex under its face, and on a
// closed slab's rim its two corners inside and its edges over the rim, not the slab's side.
TEST(MeshBox, CornersOnFacesEdgesAcrossRidgesAndPeaksUnderFaces) {
  const Vector3 half(0.1, 0.1, 0.1);
  expectUpwardAt(meshBoxContacts(*foldedSquares(0.0), Vector3(0.3, 0.2, 0.09), half, 0.01),
                 {{0.2, 0.1, 0}, {0.4, 0.1, 0}, {0.2, 0.3, 0}, {0.4, 0.3, 0}});
  expectUpwardAt(meshBoxContacts(*foldedSquares(-0.5), Vector3(0.0, 0.2, 0.09), half, 0.01),
                 {{0, 0.1, 0}, {0, 0.3, 0}});
  expectUpwardAt(meshBoxContacts(*pyramid(), Vector3(0.02, 0.03, 0.09), half, 0.01), {{0, 0, 0}});
  expectUpwardAt(meshBoxContacts(*slab(), Vector3(0.97, 0.1, 0.09), half, 0.01),
                 {{0.87, 0.0, 0}, {0.87, 0.2, 0}, {1, 0.0, 0}, {1, 0.2, 0}});
  // turned about z over the rim: still the corners on the top and two edge crossings
  Pose turned;
  turned.rotation = Eigen::AngleAxisd(0.5, Vector3::UnitZ()).toRotationMatrix();
  turned.translation = Vector3(0.97, 0.1, 0.09);
  std::vector<ContactPoint> out;
  meshBox(Pose::identity(), *slab(), turned, half, 0.01, out);
  int under = 0;  // two corners over the top, two bottom edges across the rim
  for (const ContactPoint& c : out) {
    if (c.gap >= 0.0) continue;  // a corner just past the rim, 0.0098 from the side: in front
    ++under;
    EXPECT_NEAR(c.gap, -0.01, 1e-15);
    EXPECT_NEAR((c.normal - Vector3::UnitZ()).norm(), 0.0, 1e-14);
  }
  EXPECT_EQ(under, 4);
  EXPECT_EQ(out.size(), 5u);
  // apart by more than the margin: nothing
  EXPECT_TRUE(meshBoxContacts(*slab(), Vector3(0.3, 0.2, 0.12), half, 0.01).empty());
}

// A capsule (radius 0.02) 1 cm into a mesh, lying along x: its ends on a flat patch, its side
// on a ridge and on a pyramid's apex.
TEST(MeshCapsule, EndsOnFacesSideOnRidgesAndPeaks) {
  const double r = 0.02;
  auto capsule = [&](const TriangleMesh& mesh, const Vector3& center) {
    std::vector<ContactPoint> out;
    meshCapsule(Pose::identity(), mesh, center - Vector3(0.1, 0, 0), center + Vector3(0.1, 0, 0), r,
                0.01, out);
    return out;
  };
  expectUpwardAt(capsule(*foldedSquares(0.0), Vector3(0.3, 0.2, r - 0.01)),
                 {{0.2, 0.2, 0}, {0.4, 0.2, 0}});
  expectUpwardAt(capsule(*foldedSquares(-0.5), Vector3(0.0, 0.2, r - 0.01)), {{0, 0.2, 0}});
  expectUpwardAt(capsule(*pyramid(), Vector3(0.03, 0.0, r - 0.01)), {{0, 0, 0}});
}

// A ball crossing a closed slab's top near its rim is pushed back up, not out through the
// side it is also behind.
TEST(MeshBall, APointInsideASolidLeavesThroughItsNearestFace) {
  const auto c = meshBallContacts(*slab(), Vector3(0.97, 0.1, 0.01), 0.02, 0.01);
  ASSERT_EQ(c.size(), 1u);
  EXPECT_NEAR(c[0].gap, -0.01, 1e-15);
  EXPECT_EQ(c[0].normal, Vector3::UnitZ());
}

// The tree of boxes over a mesh's triangles gives the closed forms the contacts a visit of every
// triangle gives: the bowl (240 triangles) against random balls, boxes and capsules near it,
// compared with the same mesh whose tree is one leaf holding all.
TEST(MeshTree, ClosedFormsSeeEveryTriangleTheyNeed) {
  const auto bowl =
      Shape::triangleMesh(loadTriangleMesh(std::string(SWEEP_TEST_DATA) + "/meshes/bowl.stl")).mesh;
  ASSERT_GT(bowl->tree.size(), 1u);
  auto flat = std::make_shared<TriangleMesh>(*bowl);
  flat->tree.assign(1, {});
  flat->tree[0].lower = Vector3::Constant(-1e300);
  flat->tree[0].upper = Vector3::Constant(1e300);
  flat->tree[0].end = static_cast<int>(flat->triangles.size());
  flat->tree_triangles.resize(flat->triangles.size());
  for (std::size_t t = 0; t < flat->triangles.size(); ++t) flat->tree_triangles[t] = int(t);
  auto key = [](const std::vector<ContactPoint>& points) {
    std::vector<std::pair<int, double>> k;
    for (const ContactPoint& p : points) k.emplace_back(p.feature, p.gap);
    std::sort(k.begin(), k.end());
    return k;
  };
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int contacts = 0;
  for (int draw = 0; draw < 400; ++draw) {
    Pose pose;
    pose.rotation =
        Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized().toRotationMatrix();
    // near the surface: a point of the sphere of radius 0.25 about (0, 0, 0.25), low in it
    const Vector3 direction = Vector3(u(rng), u(rng), -1.5 + 0.5 * u(rng)).normalized();
    pose.translation = Vector3(0, 0, 0.25) + (0.22 + 0.03 * u(rng)) * direction;
    const Vector3 half(0.02 + 0.01 * u(rng), 0.03, 0.015);
    std::vector<ContactPoint> tree_out, flat_out;
    meshBox(Pose::identity(), *bowl, pose, half, 0.01, tree_out);
    meshBox(Pose::identity(), *flat, pose, half, 0.01, flat_out);
    const Vector3 end = pose.apply(Vector3(0, 0, 0.04));
    meshCapsule(Pose::identity(), *bowl, pose.translation, end, 0.015, 0.01, tree_out);
    meshCapsule(Pose::identity(), *flat, pose.translation, end, 0.015, 0.01, flat_out);
    meshBall(Pose::identity(), *bowl, pose.translation, 0.03, 0.01,
             [&](const ContactPoint& c) { tree_out.push_back(c); });
    meshBall(Pose::identity(), *flat, pose.translation, 0.03, 0.01,
             [&](const ContactPoint& c) { flat_out.push_back(c); });
    ASSERT_EQ(key(tree_out), key(flat_out)) << "draw " << draw;
    contacts += static_cast<int>(tree_out.size());
  }
  EXPECT_GT(contacts, 400);  // the draws touch the bowl
}

// Capsule against capsule: crossing axes meet at their common normal, parallel ones at both
// ends of their overlap, axes end to end at their ends, each once.
TEST(SegmentSegment, CrossingParallelAndEndToEnd) {
  auto contacts = [](const Vector3& a0, const Vector3& a1, const Vector3& b0, const Vector3& b1) {
    std::vector<ContactPoint> out;
    segmentSegment(a0, a1, 0.02, b0, b1, 0.03, 0.01,
                   [&](const ContactPoint& c) { out.push_back(c); });
    return out;
  };
  // crossing: a along x at z = 0, b along y at z = 0.045 (overlap 0.005)
  const auto crossing =
      contacts({-0.1, 0, 0}, {0.1, 0, 0}, {0.02, -0.1, 0.045}, {0.02, 0.1, 0.045});
  ASSERT_EQ(crossing.size(), 1u);
  EXPECT_EQ(crossing[0].feature, 4);
  EXPECT_NEAR(crossing[0].gap, -0.005, 1e-15);
  EXPECT_NEAR((crossing[0].normal - Vector3::UnitZ()).norm(), 0.0, 1e-15);
  EXPECT_NEAR((crossing[0].point_a - Vector3(0.02, 0, 0.02)).norm(), 0.0, 1e-15);
  // side by side, b shifted along x: a point at each end of the overlap [0, 0.1]
  const auto parallel = contacts({-0.1, 0, 0}, {0.1, 0, 0}, {0.0, 0, 0.045}, {0.2, 0, 0.045});
  ASSERT_EQ(parallel.size(), 2u);
  for (const ContactPoint& c : parallel) {
    EXPECT_NEAR(c.gap, -0.005, 1e-15);
    EXPECT_NEAR((c.normal - Vector3::UnitZ()).norm(), 0.0, 1e-15);
  }
  EXPECT_EQ(parallel[0].feature, 1);  // a's end at x = 0.1
  EXPECT_EQ(parallel[1].feature, 2);  // b's start at x = 0
  // end to end along x, 0.04 apart (gap -0.01): one contact, from a's end
  const auto ends = contacts({-0.1, 0, 0}, {0.1, 0, 0}, {0.14, 0, 0}, {0.3, 0, 0});
  ASSERT_EQ(ends.size(), 1u);
  EXPECT_EQ(ends[0].feature, 1);
  EXPECT_NEAR(ends[0].gap, -0.01, 1e-15);
  EXPECT_NEAR((ends[0].normal - Vector3::UnitX()).norm(), 0.0, 1e-15);
  // apart by more than the margin: nothing
  EXPECT_TRUE(contacts({-0.1, 0, 0}, {0.1, 0, 0}, {0, -0.1, 0.07}, {0, 0.1, 0.07}).empty());
}

// A capsule across a box narrower than itself, its axis tilting down from one rim to the other:
// the lower rim holds it by the edge-axis point, the higher by its crossing against the top
// face (held by one rim at a time, a capsule rocks from rim to rim and sinks at each change).
TEST(MeshCapsule, AcrossANarrowRimBothRimsHoldIt) {
  const auto box = closedBoxMesh(Vector3(0.1, 0.02, 0.01));  // top at z = 0.01, rims y = +-0.02
  std::vector<ContactPoint> out;
  meshCapsule(Pose::identity(), *box, Vector3(0, -0.1, 0.0305), Vector3(0, 0.1, 0.0295), 0.02, 0.01,
              out);
  ASSERT_EQ(out.size(), 2u);
  const auto face = std::find_if(out.begin(), out.end(),
                                 [](const ContactPoint& c) { return c.point_a.y() < 0.0; });
  ASSERT_NE(face, out.end());
  EXPECT_NEAR(face->gap, 0.0301 - 0.01 - 0.02, 1e-15);
  EXPECT_NEAR((face->normal - Vector3::UnitZ()).norm(), 0.0, 1e-15);
  EXPECT_NEAR((face->point_a - Vector3(0, -0.02, 0.01)).norm(), 0.0, 1e-15);
  const ContactPoint& rim = out[face == out.begin() ? 1 : 0];
  EXPECT_NEAR(rim.point_a.y(), 0.02, 1e-15);
  EXPECT_NEAR(rim.point_a.z(), 0.01, 1e-15);
  EXPECT_GT(rim.normal.y(), 0.0);  // tilted out over the lower rim
  EXPECT_LT(rim.gap, face->gap);
}

}  // namespace
}  // namespace sweep
