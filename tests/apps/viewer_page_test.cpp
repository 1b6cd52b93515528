// The viewer's page budget: thinned to fit when --every is not given, refused naming the one that
// fits when it is.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "apps/sweep/run.hpp"
#include "apps/sweep/scene_file.hpp"
#include "apps/sweep/viewer.hpp"
#include "apps/sweep/vtk_writer.hpp"
#include "framework/error.hpp"
#include "integrators/time_stepper.hpp"

namespace sweep {
namespace {

TEST(ViewerPage, KeepsEveryNthSnapshotAndTheLast) {
  EXPECT_EQ(keptSnapshots(1, 1), 1u);
  EXPECT_EQ(keptSnapshots(10, 1), 10u);
  EXPECT_EQ(keptSnapshots(10, 3), 4u);  // 0, 3, 6 and 9, the last
  EXPECT_EQ(keptSnapshots(11, 3), 5u);  // 0, 3, 6, 9 and the last, 10
  EXPECT_EQ(keptSnapshots(10, 100), 2u);
}

TEST(ViewerPage, ThinsToTheSmallestEveryThatFitsOrRefusesAGivenOne) {
  // 10 000 snapshots of 200 kB: 2 GB of page at --every 1; 500 MB holds 2 500 of them
  ViewerPage page{10000, 2e5, 8e5, 1e12};
  std::ostringstream log;
  const int every = fittingEvery(page, 0, &log);
  EXPECT_LE(static_cast<double>(keptSnapshots(10000, every)) * 2e5, kMaxViewerPageBytes);
  EXPECT_GT(static_cast<double>(keptSnapshots(10000, every - 1)) * 2e5, kMaxViewerPageBytes);
  EXPECT_NE(log.str().find("view: keeping every " + std::to_string(every) + "-th snapshot"),
            std::string::npos)
      << log.str();
  EXPECT_EQ(fittingEvery(page, every + 3, nullptr), every + 3);
  try {
    fittingEvery(page, 2, nullptr);
    ADD_FAILURE() << "an --every whose page does not fit was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--every 2: 10000 snapshots of 200 kB each make a page "
                                         "past the 500 MB a browser opens"),
              std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("--every " + std::to_string(every) + " fits"),
              std::string::npos)
        << e.what();
  }
  // the memory limit binds first when it is the smaller
  page.memory_limit = 8e7;  // 100 snapshots
  EXPECT_EQ(keptSnapshots(10000, fittingEvery(page, 0, nullptr)), 100u);
  // a small run is left whole and silent
  std::ostringstream quiet;
  EXPECT_EQ(fittingEvery(ViewerPage{50, 1e3, 4e3, 1e12}, 0, &quiet), 1);
  EXPECT_EQ(quiet.str(), "");
  // one snapshot beyond the page: nothing fits
  EXPECT_THROW(fittingEvery(ViewerPage{3, 3e8, 1.2e9, 1e12}, 0, nullptr), InputError);
}

// A robot's links are drawn by their visuals: the page takes the UR10's seven visual boxes
// (12 triangles each) and its ee_link box (6 faces), not the collision hulls under them, and
// refuses a role it does not know, naming the field.
TEST(ViewerPage, ALinkIsDrawnByItsVisualsNotItsCollisionShapes) {
  const std::string scene_path =
      std::string(SWEEP_SOURCE_DIR) + "/tests/data/packages/scenes/ur10_on_floor.yaml";
  const SceneFile file = loadSceneFile(scene_path);
  const Scene scene = buildSceneFile(file);
  ASSERT_EQ(scene.model.visuals.size(), 7u);
  TimeStepper stepper(scene.model, scene.cmodel, file.run.scheme, scene.forces);
  stepper.reset(0.0, scene.q0, scene.v0);
  stepper.step();
  const std::string dir =
      (std::filesystem::temp_directory_path() / "sweep_viewer_visuals").string();
  std::filesystem::remove_all(dir);
  {
    VtkSeries series(scene, dir);
    series.write(stepper);
  }
  std::ifstream in(dir + "/vtk/snapshot_000000.vtp");
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(readViewerSnapshot("snapshot_000000.vtp", text.str()), 7 * 12 + 6);
  std::string bad = text.str();
  const std::size_t role = bad.find("Name=\"role\" format=\"ascii\">\n");
  ASSERT_NE(role, std::string::npos);
  bad[bad.find('>', role) + 2] = '7';
  try {
    readViewerSnapshot("snapshot_000000.vtp", bad);
    ADD_FAILURE() << "role 7 was taken";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("role: must be 0, 1 or 2"), std::string::npos) << e.what();
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace sweep
