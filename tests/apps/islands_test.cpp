// The contact islands on threads (integrators/contact_assembly.cpp, numberIslands): the rows'
// union-find runs on every thread from 8192 rows, and must give the islands of one thread, in
// the same order, and islands that are the connected sets of rows.
#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <string>
#include <vector>

#include "apps/sweep/scene_file.hpp"
#include "integrators/time_stepper.hpp"

namespace sweep {
namespace {

// 6 000 touching disks in two piles 2 cm apart (two islands: walls and floor are fixed),
// stepped once (one sweep: the islands are the point): about 12 000 closed contacts
SceneFile twoTouchingPiles(int threads) {
  std::string text = R"(dimension: 2
gravity: [0, -9.81]
materials: {steel: {density: 7800}}
contact: {friction: 0.3, restitution: 0}
bodies:
  - {name: floor, shape: half_plane, position: [0, 0], normal: [0, 1], fixed: true}
  - {name: left, shape: half_plane, position: [0, 0], normal: [1, 0], fixed: true}
  - {name: right, shape: half_plane, position: [0.8, 0], normal: [-1, 0], fixed: true}
generators:
  - {type: disks, name: a, material: steel, count: 3000, radius: 1e-3, region: {min: [0, 0], max: [0.39, 1.0]}, spacing: 1.0}
  - {type: disks, name: b, material: steel, count: 3000, radius: 1e-3, region: {min: [0.41, 0], max: [0.8, 1.0]}, spacing: 1.0}
scheme: {name: moreau-jean, coulomb: {max_iterations: 1}, threads: )";
  text += std::to_string(threads) + "}\ntime: {step: 1e-4, end: 1e-4}\n";
  return loadSceneText(text, "two_piles.yaml");
}

struct Islands {
  std::vector<int> begin, rows;
  std::vector<std::array<int, 2>> components;
};

Islands islandsOn(int threads) {
  SceneFile file = twoTouchingPiles(threads);
  const Scene scene = buildSceneFile(file);
  TimeStepper stepper(scene.model, scene.cmodel, file.run.scheme, scene.forces);
  stepper.reset(0.0, scene.q0, scene.v0);
  stepper.step();
  const ContactProblem& p = stepper.problem();
  return {p.island_begin, p.island_rows, p.row_components};
}

TEST(Islands, ThreadsGiveTheIslandsOfOneThread) {
  const Islands one = islandsOn(1);
  const int n = static_cast<int>(one.rows.size());
  ASSERT_GT(n, 8192) << "the union-find runs on threads from 8192 rows";
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
    const Islands other = islandsOn(threads);
    EXPECT_EQ(other.begin, one.begin) << threads << " threads";
    EXPECT_EQ(other.rows, one.rows) << threads << " threads";
  }
}

}  // namespace
}  // namespace sweep
