// The contact islands on threads (integrators/contact_assembly.cpp, numberIslands): the rows'
// union-find runs on every thread from kParallelItems rows, and must give the islands of one
// thread, in the same order, and islands that are the connected sets of rows.
#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <string>
#include <vector>

#include "framework/parallel.hpp"
#include "integrators/time_stepper.hpp"
#include "models/scene_spec.hpp"

namespace sweep {
namespace {

// Two square lattices of 3 000 touching disks each, 2 cm apart on a floor between two walls:
// two islands (floor and walls are fixed), about 12 000 closed contacts in the first step
Scene twoTouchingPiles() {
  SceneSpec spec;
  spec.dimension = 2;
  spec.materials.push_back({"steel", 7800.0});
  spec.default_law = ContactLaw{0.3, 0.0};
  auto wall = [&](const std::string& name, const Vector3& at, double angle) {
    BodySpec body;
    body.name = name;
    body.kind = BodySpec::Kind::Fixed;
    body.shape = Shape::halfPlane();
    body.pose.translation = at;
    body.pose.rotation = Eigen::AngleAxisd(angle, Vector3::UnitZ()).toRotationMatrix();
    spec.bodies.push_back(body);
  };
  wall("floor", Vector3::Zero(), 0.0);
  wall("left", Vector3::Zero(), -0.5 * M_PI);
  wall("right", Vector3(0.41, 0.0, 0.0), 0.5 * M_PI);
  const double r = 1e-3;
  for (int pile = 0; pile < 2; ++pile)
    for (int k = 0; k < 3000; ++k) {
      BodySpec disk;
      disk.name = "d" + std::to_string(pile) + "_" + std::to_string(k);
      disk.shape = Shape::disk(r);
      disk.material = "steel";
      disk.pose.translation =
          Vector3(pile * 0.21 + r + 2 * r * (k % 95), r + 2 * r * (k / 95), 0.0);
      spec.bodies.push_back(disk);
    }
  return buildScene(spec);
}

struct Islands {
  std::vector<int> begin, rows;
  std::vector<std::array<int, 2>> components;
};

Islands islandsOn(const Scene& scene, int threads) {
  SchemeSettings settings;
  settings.scheme = Scheme::MoreauJean;
  settings.h = 1e-4;
  settings.coulomb.max_iterations = 1;  // the islands are the point
  settings.threads = threads;
  TimeStepper stepper(scene.model, scene.cmodel, settings, scene.forces);
  stepper.reset(0.0, scene.q0, scene.v0);
  stepper.step();
  const ContactProblem& p = stepper.problem();
  return {p.island_begin, p.island_rows, p.row_components};
}

TEST(Islands, ThreadsGiveTheIslandsOfOneThread) {
  const Scene scene = twoTouchingPiles();
  const Islands one = islandsOn(scene, 1);
  const int n = static_cast<int>(one.rows.size());
  ASSERT_GT(n, kParallelItems) << "the union-find runs on threads from kParallelItems rows";
  ASSERT_GE(one.begin.size(), 3u) << "the two piles are two islands at least";
  // the islands are the connected sets of rows: a plain serial union-find over the rows'
  // components gives one root per island, a different one for each, and the islands come in
  // order of their first rows
  std::vector<int> parent;
  auto find = [&](int c) {
    while (parent[c] != c) c = parent[c];
    return c;
  };
  for (const std::array<int, 2>& moved : one.components)
    for (int c : moved)
      if (c >= static_cast<int>(parent.size())) {
        const int old = static_cast<int>(parent.size());
        parent.resize(c + 1);
        std::iota(parent.begin() + old, parent.end(), old);
      }
  for (const std::array<int, 2>& moved : one.components)
    if (moved[0] >= 0 && moved[1] >= 0) parent[find(moved[0])] = find(moved[1]);
  auto rootOf = [&](int row) {
    const std::array<int, 2>& moved = one.components[row];
    return find(moved[0] >= 0 ? moved[0] : moved[1]);
  };
  std::vector<int> island_root;
  int first_row = -1;
  for (std::size_t i = 0; i + 1 < one.begin.size(); ++i) {
    const int root = rootOf(one.rows[one.begin[i]]);
    EXPECT_GT(one.rows[one.begin[i]], first_row) << "islands in order of their first row";
    first_row = one.rows[one.begin[i]];
    for (int k = one.begin[i]; k < one.begin[i + 1]; ++k) {
      EXPECT_EQ(rootOf(one.rows[k]), root) << "island " << i;
      if (k > one.begin[i]) {
        EXPECT_LT(one.rows[k - 1], one.rows[k]) << "rows keep their order";
      }
    }
    EXPECT_EQ(std::count(island_root.begin(), island_root.end(), root), 0) << "island " << i;
    island_root.push_back(root);
  }
  for (int threads : {2, 3}) {
    const Islands other = islandsOn(scene, threads);
    EXPECT_EQ(other.begin, one.begin) << threads << " threads";
    EXPECT_EQ(other.rows, one.rows) << threads << " threads";
  }
}

}  // namespace
}  // namespace sweep
