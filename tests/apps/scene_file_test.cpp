// Scene files: the malformed catalogue (exact messages), what a valid file builds, the Hall
// funnel as generator and as explicit file, --set overrides and settings files, and a run's summary
// against its own per-step record.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <string>
#include <vector>

#include "apps/sweep/run.hpp"
#include "apps/sweep/scene_file.hpp"
#include "apps/sweep/yaml_field.hpp"
#include "framework/error.hpp"
#include "integrators/time_stepper.hpp"
#include "models/funnel.hpp"

namespace sweep {
namespace {

namespace fs = std::filesystem;

// Scene paths in messages are as given: run from the scenes folder with relative paths.
class InScenesFolder : public ::testing::Test {
 protected:
  void SetUp() override {
    previous_ = fs::current_path();
    fs::current_path(std::string(SWEEP_TEST_DATA) + "/scenes");
  }
  void TearDown() override { fs::current_path(previous_); }
  fs::path previous_;
};

std::string expectedMessage(const fs::path& file) {
  std::ifstream in(file);
  std::string first;
  std::getline(in, first);
  const std::string tag = "# expect: ";
  return first.rfind(tag, 0) == 0 ? first.substr(tag.size()) : "";
}

// Loads each file of `folder` with `load` and compares the InputError with the file's
// `# expect:` line; returns how many files it checked.
template <typename Load>
int expectEachRejectedWithItsMessage(const std::string& folder, Load load) {
  int checked = 0;
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(folder)) files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  for (const fs::path& file : files) {
    const std::string expected = expectedMessage(file);
    EXPECT_FALSE(expected.empty()) << file << " has no '# expect:' line";
    std::string got;
    try {
      load(file.string());
    } catch (const InputError& e) {
      got = e.what();
    }
    EXPECT_EQ(got, expected) << file;
    ++checked;
  }
  return checked;
}

TEST_F(InScenesFolder, EveryMalformedSceneIsRejectedWithItsExactMessage) {
  const int checked = expectEachRejectedWithItsMessage(
      "bad", [](const std::string& file) { buildSceneFile(loadSceneFile(file)); });
  EXPECT_GE(checked, 50);
}

// The overlap check has a documented way out: a negative tolerance turns it off, and the
// overlapping pair then builds (and a run pushes it apart).
TEST_F(InScenesFolder, InitialOverlapCheckCanBeRelaxed) {
  EXPECT_THROW(buildSceneFile(loadSceneFile("bad/overlapping_disks.yaml")), InputError);
  const SceneFile relaxed =
      loadSceneFile("bad/overlapping_disks.yaml", {"detection.max_initial_overlap=2e-3"});
  EXPECT_EQ(buildSceneFile(relaxed).model.nv, 6);
  const SceneFile off =
      loadSceneFile("bad/overlapping_disks.yaml", {"detection.max_initial_overlap=-1"});
  EXPECT_EQ(buildSceneFile(off).model.nv, 6);
}

TEST_F(InScenesFolder, SmallBoxBuildsWhatItSays) {
  const SceneFile file = loadSceneFile("small_box.yaml");
  EXPECT_EQ(file.spec.dimension, 2);
  EXPECT_EQ(file.spec.bodies.size(), 24u + 4u);
  EXPECT_EQ(file.run.scheme.scheme, Scheme::CatchingUp);
  EXPECT_DOUBLE_EQ(file.run.scheme.h, 1e-4);
  EXPECT_DOUBLE_EQ(file.run.t_end, 0.02);
  EXPECT_EQ(file.run.output.vtk_every, 50);
  const Scene scene = buildSceneFile(file);
  EXPECT_EQ(scene.model.nv, 3 * 24);
  EXPECT_EQ(scene.model.driven_bodies.size(), 1u);
  const MaterialTable& m = scene.cmodel.materials;
  EXPECT_DOUBLE_EQ(m.law(m.id("steel"), m.id("wall")).friction, 0.4);
  EXPECT_DOUBLE_EQ(m.law(m.id("steel"), m.id("steel")).friction, 0.3);
  // masses from the density: m = rho pi r^2
  const Body& first = scene.model.bodies[scene.model.bodyIndex("disk0")];
  const double r = file.spec.bodies[0].shape.radius;
  EXPECT_NEAR(first.inertia.mass, 7800.0 * M_PI * r * r, 1e-12);
  EXPECT_NEAR(first.inertia.inertia_com(2, 2), 0.5 * first.inertia.mass * r * r, 1e-15);
}

TEST_F(InScenesFolder, OverridesReachTheScene) {
  const SceneFile file = loadSceneFile(
      "small_box.yaml", {"time.step=5e-5", "scheme.normal_law=pos", "generators[0].count=10",
                         "contact.friction=0", "scheme.open_contacts=free"});
  EXPECT_DOUBLE_EQ(file.run.scheme.h, 5e-5);
  EXPECT_EQ(file.run.scheme.normal_law, NormalLaw::Pos);
  EXPECT_EQ(file.run.scheme.friction.open_contacts, OpenContacts::Free);
  EXPECT_EQ(file.spec.bodies.size(), 10u + 4u);
  EXPECT_DOUBLE_EQ(file.spec.default_law.friction, 0.0);
  // a typo is caught by the same validation as the file itself
  EXPECT_THROW(loadSceneFile("small_box.yaml", {"time.stepp=1"}), InputError);
  EXPECT_THROW(loadSceneFile("small_box.yaml", {"generators[7].count=1"}), InputError);
  EXPECT_THROW(loadSceneFile("small_box.yaml", {"no_equals_sign"}), InputError);
}

TEST_F(InScenesFolder, SettingsFilesReachTheSceneAndTheCommandLineWins) {
  const SceneFile file = loadSceneFile("small_box.yaml", {}, {"settings/small_box_fine.yaml"});
  EXPECT_DOUBLE_EQ(file.run.scheme.h, 5e-5);
  EXPECT_EQ(file.run.scheme.normal_law, NormalLaw::Pos);
  EXPECT_EQ(file.spec.bodies.size(), 10u + 4u);
  EXPECT_DOUBLE_EQ(file.spec.default_law.friction, 0.0);
  EXPECT_DOUBLE_EQ(file.run.scheme.coulomb.tolerance, 1e-3);
  EXPECT_EQ(file.run.scheme.coulomb.acceleration, NlgsAcceleration::Nncg);
  // the fields the settings file leaves alone keep the scene's values
  EXPECT_EQ(file.run.scheme.scheme, Scheme::CatchingUp);
  EXPECT_DOUBLE_EQ(file.run.t_end, 0.02);

  const SceneFile both =
      loadSceneFile("small_box.yaml", {"time.step=2e-5"}, {"settings/small_box_fine.yaml"});
  EXPECT_DOUBLE_EQ(both.run.scheme.h, 2e-5);
  EXPECT_EQ(both.run.scheme.normal_law, NormalLaw::Pos);
}

TEST_F(InScenesFolder, EveryMalformedSettingsFileIsRejectedWithItsExactMessage) {
  const int checked = expectEachRejectedWithItsMessage(
      "settings/bad", [](const std::string& file) { loadSceneFile("small_box.yaml", {}, {file}); });
  EXPECT_GE(checked, 7);
  try {
    loadSceneFile("small_box.yaml", {}, {"settings/none.yaml"});
    ADD_FAILURE() << "a missing settings file was accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "settings/none.yaml: cannot open the file");
  }
}

// The powder bed's faster setting is a settings file next to the scene: every entry it
// holds must keep reaching the field the documentation says it sets.
TEST(SettingsFile, PowderBedFastSettingIsWhatTheDocsMeasured) {
  const std::string folder = std::string(SWEEP_SOURCE_DIR) + "/examples/powder_bed/";
  const SceneFile file = loadSceneFile(folder + "powder_bed.yaml", {}, {folder + "fast.yaml"});
  const SchemeSettings& s = file.run.scheme;
  EXPECT_EQ(s.scheme, Scheme::MoreauJean);
  EXPECT_EQ(s.normal_law, NormalLaw::Iqs);
  EXPECT_DOUBLE_EQ(s.h, 1e-4);
  EXPECT_TRUE(s.screening);
  EXPECT_DOUBLE_EQ(s.coulomb.tolerance, 1e-2);
  EXPECT_EQ(s.coulomb.residual_check_interval, 5);
  EXPECT_DOUBLE_EQ(s.coulomb.relaxation, 0.9);
  EXPECT_DOUBLE_EQ(s.normal_stage.tolerance, 1e-2);
  EXPECT_DOUBLE_EQ(s.friction_stage.tolerance, 1e-2);
  // the scene's own solver choice survives: the entries set fields, not the whole section
  EXPECT_EQ(s.coulomb.acceleration, NlgsAcceleration::Nncg);
  EXPECT_EQ(file.spec.detection.margin_rule, MarginRule::Relative);
  EXPECT_DOUBLE_EQ(file.spec.detection.speed_factor, 1.25);
  EXPECT_TRUE(s.compactSphereRows());
}

TEST(SceneSpec, PolygonAndSegmentInertiasMatchTheirClosedForms) {
  BodySpec square;
  square.name = "square";
  square.shape = Shape::polygon({Vector2(0, 0), Vector2(2, 0), Vector2(2, 2), Vector2(0, 2)});
  const Inertia a = bodyInertia(square, 3.0, 2);
  EXPECT_NEAR(a.mass, 12.0, 1e-12);
  EXPECT_TRUE(a.com.isApprox(Vector3(1, 1, 0)));
  EXPECT_NEAR(a.inertia_com(2, 2), 12.0 * (4.0 + 4.0) / 12.0, 1e-12);  // m (a^2 + b^2) / 12
  // a rounded segment of length 0 is a disk
  BodySpec dot;
  dot.name = "dot";
  dot.shape = Shape::segment(Vector2(0, 0), Vector2(1e-9, 0), 0.5);
  const Inertia b = bodyInertia(dot, 1.0, 2);
  EXPECT_NEAR(b.mass, M_PI * 0.25, 1e-8);
  EXPECT_NEAR(b.inertia_com(2, 2), 0.5 * b.mass * 0.25, 1e-8);
}

TEST(SceneFile, FunnelFileAndGeneratorGiveTheSameScene) {
  const SceneFile file =
      loadSceneFile(std::string(SWEEP_SOURCE_DIR) + "/examples/funnel/funnel.yaml");
  const SceneSpec direct = hallFunnel(FunnelParameters{});
  ASSERT_EQ(file.spec.bodies.size(), direct.bodies.size());
  for (std::size_t i = 0; i < direct.bodies.size(); ++i) {
    EXPECT_EQ(file.spec.bodies[i].name, direct.bodies[i].name);
    EXPECT_EQ(file.spec.bodies[i].shape.radius, direct.bodies[i].shape.radius);
    EXPECT_EQ(file.spec.bodies[i].pose.translation, direct.bodies[i].pose.translation);
  }
}

TEST(SceneFile, ExportedFunnelLoadsBackToTheSameScene) {
  const SceneFile file =
      loadSceneFile(std::string(SWEEP_SOURCE_DIR) + "/examples/funnel/funnel.yaml");
  const std::string path = ::testing::TempDir() + "/funnel_explicit.yaml";
  writeSceneFile(file, path);
  const SceneFile back = loadSceneFile(path);
  ASSERT_EQ(back.spec.bodies.size(), file.spec.bodies.size());
  for (std::size_t i = 0; i < file.spec.bodies.size(); ++i) {
    const BodySpec& a = file.spec.bodies[i];
    const BodySpec& b = back.spec.bodies[i];
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.kind, b.kind);
    EXPECT_EQ(a.shape.radius, b.shape.radius);
    EXPECT_EQ(a.pose.translation, b.pose.translation);
    EXPECT_EQ(a.shape.segment_start, b.shape.segment_start);
    EXPECT_EQ(a.motion.removal_time, b.motion.removal_time);
  }
  EXPECT_EQ(back.run.scheme.h, file.run.scheme.h);
  EXPECT_EQ(back.run.scheme.friction.open_contacts, file.run.scheme.friction.open_contacts);
  // and the two run identically
  RunSettings settings = file.run;
  settings.t_end = 0.005;
  const RunSummary x = runScene(buildSceneFile(file), settings, {});
  const RunSummary y = runScene(buildSceneFile(back), settings, {});
  EXPECT_EQ(x.penetration_cumulative, y.penetration_cumulative);
  EXPECT_EQ(x.energy_final, y.energy_final);
}

// Every example scene, exported and loaded back, is the same run: its export is a fixed point
// (settings, detection and outputs included) and three steps of each give the same bits.
TEST(SceneFile, EveryExampleExportsToTheSameRun) {
  const fs::path examples = fs::path(SWEEP_SOURCE_DIR) / "examples";
  std::vector<fs::path> scenes;
  for (const auto& entry : fs::recursive_directory_iterator(examples)) {
    if (entry.path().extension() != ".yaml") continue;
    std::ifstream in(entry.path());
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (text.find("\ndimension:") != std::string::npos || text.rfind("dimension:", 0) == 0)
      scenes.push_back(entry.path());  // settings files (fast.yaml) hold no dimension
  }
  std::sort(scenes.begin(), scenes.end());
  ASSERT_GE(scenes.size(), 15u);
  const auto read = [](const std::string& path) {
    std::ifstream in(path);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    return text.substr(text.find('\n'));  // past the line naming the source
  };
  for (const fs::path& path : scenes) {
    SCOPED_TRACE(path.string());
    const SceneFile file = loadSceneFile(path.string());
    const std::string once = ::testing::TempDir() + "/" + path.stem().string() + "_once.yaml";
    const std::string twice = ::testing::TempDir() + "/" + path.stem().string() + "_twice.yaml";
    writeSceneFile(file, once);
    const SceneFile back = loadSceneFile(once);
    writeSceneFile(back, twice);
    EXPECT_EQ(read(once), read(twice));
    const Scene a = buildSceneFile(file), b = buildSceneFile(back);
    ASSERT_EQ(a.q0.size(), b.q0.size());
    EXPECT_EQ(a.q0, b.q0);
    EXPECT_EQ(a.v0, b.v0);
    EXPECT_EQ(a.cmodel.geometries.size(), b.cmodel.geometries.size());
    TimeStepper x(a.model, a.cmodel, file.run.scheme, a.forces);
    TimeStepper y(b.model, b.cmodel, back.run.scheme, b.forces);
    x.reset(0.0, a.q0, a.v0);
    y.reset(0.0, b.q0, b.v0);
    for (int k = 0; k < 3; ++k) {
      x.step();
      y.step();
    }
    EXPECT_EQ(x.q(), y.q());
    EXPECT_EQ(x.v(), y.v());
    EXPECT_EQ(back.run.output.layer.has_value(), file.run.output.layer.has_value());
    EXPECT_EQ(back.spec.detection.periodic.axis, file.spec.detection.periodic.axis);
  }
}

// A ball, a box and a capsule (lying, and tilted onto one end) dropped on a fixed mesh slab
// (convex: false, or true: the same surface) or a fixed box land and rest as they do on a
// plane at the slab's top, in both schemes, under VEL and POS: the closed forms of mesh pairs
// (a box as its surface mesh) give the plane's gaps and normals. FCL's pairs let the ball fall
// through the mesh and the box sink into it, let a capsule rest 8 mm inside a box under VEL, and
// threw a capsule or a box off a box floor under POS (1.8 J from 0.1 J).
TEST_F(InScenesFolder, ShapesRestOnATriangleMeshOrABoxAsOnAPlane) {
  const std::vector<std::string> parts = {
      "shape: sphere, radius: 0.05", "shape: box, size: [0.1, 0.1, 0.1], rpy: [0.3, 0.2, 0.1]",
      "shape: capsule, radius: 0.02, length: 0.1, rpy: [1.5707963, 0, 0]",
      "shape: capsule, radius: 0.02, length: 0.1, rpy: [0.3, 0.2, 0]"};
  const std::string plane = "  - {name: floor, shape: plane, normal: [0, 0, 1], fixed: true}\n";
  const std::vector<std::string> floors = {
      "  - {name: floor, shape: mesh, file: ../meshes/cube.stl, scale: [2, 2, 0.2], "
      "convex: false, fixed: true, position: [0, 0, -0.1]}\n",
      "  - {name: floor, shape: mesh, file: ../meshes/cube.stl, scale: [2, 2, 0.2], "
      "convex: true, fixed: true, position: [0, 0, -0.1]}\n",
      "  - {name: floor, shape: box, size: [2, 2, 0.2], fixed: true, position: [0, 0, -0.1]}\n"};
  for (const std::string& part : parts) {
    const std::string body = "  - {name: part, " + part +
                             ", mass: 1, position: [0.1, 0.13, 0.3]}\n"
                             "time: {step: 1.0e-3, end: 0.6}\n";
    for (const char* scheme : {"moreau-jean", "catching-up"})
      for (const char* law : {"vel", "pos"}) {
        auto rest = [&](const std::string& floor, const char* path = "automatic") {
          const SceneFile file = loadSceneText(
              "dimension: 3\nbodies:\n" + floor + body, "floor.yaml",
              {std::string("scheme.name=") + scheme, std::string("scheme.normal_law=") + law,
               std::string("detection.path=") + path},
              {});
          const Scene scene = buildSceneFile(file);
          TimeStepper stepper(scene.model, scene.cmodel, file.run.scheme, scene.forces);
          stepper.reset(0.0, scene.q0, scene.v0);
          for (int k = 0; k < 600; ++k) stepper.step();
          return VectorX(stepper.q());
        };
        const VectorX on_plane = rest(plane);
        EXPECT_GT(on_plane[2], 0.015);  // resting above z = 0
        for (const std::string& floor : floors) {
          SCOPED_TRACE(part + ", " + scheme + ", " + law + ", " + floor);
          // under POS the gaps' round-off (the mesh frame's against the plane's, 1e-17) enters
          // the bias 2 g / h, and the solves stop at their tolerance on other iterates
          const double agree = std::string(law) == "vel" ? 1e-12 : 1e-8;
          EXPECT_LT((rest(floor) - on_plane).lpNorm<Eigen::Infinity>(), agree);
        }
        // on FCL's path too, the closed forms take a convex mesh's pairs
        EXPECT_LT((rest(floors[1], "fcl") - on_plane).lpNorm<Eigen::Infinity>(),
                  std::string(law) == "vel" ? 1e-12 : 1e-8);
      }
  }
}

// 48 boxes, capsules and spheres dropped into a box-walled bin (tests/data/scenes/bin.yaml),
// 0.5 s, both schemes under every normal law: the energy never rises above its start (POS ran
// away on FCL's box gaps), and under POS the overlap at the end is below 1 % of the smallest
// size (1 cm). VEL and IQS keep what the impacts left (1.4-1.6 mm, 0.5 mm: docs/schemes.md);
// VEL with the position projection ends within its tolerance, and peaks below 1 %.
TEST_F(InScenesFolder, ABinOfBoxesCapsulesAndSpheresUnderEveryNormalLaw) {
  for (const char* scheme : {"moreau-jean", "catching-up"})
    for (const char* law : {"vel", "iqs", "pos", "vel+projection"}) {
      SCOPED_TRACE(std::string(scheme) + ", " + law);
      const bool projection = std::string(law) == "vel+projection";
      const SceneFile file = loadSceneFile(
          "bin.yaml", {std::string("scheme.name=") + scheme,
                       std::string("scheme.normal_law=") + (projection ? "vel" : law),
                       std::string("scheme.projection.max_rounds=") + (projection ? "3" : "0"),
                       "time.end=0.5"});
      const Scene scene = buildSceneFile(file);
      TimeStepper stepper(scene.model, scene.cmodel, file.run.scheme, scene.forces);
      stepper.reset(0.0, scene.q0, scene.v0);
      const double start = stepper.energy();
      double highest = start, overlap = 0.0, peak = 0.0;
      for (int k = 0; k < 500; ++k) {
        overlap = stepper.step().penetration_max;
        peak = std::max(peak, overlap);
        highest = std::max(highest, stepper.energy());
      }
      EXPECT_TRUE(stepper.q().allFinite());
      EXPECT_LE(highest, start * (1.0 + 1e-12));
      EXPECT_LT(stepper.energy(), 0.2 * start);  // landed: most of the fall dissipated
      if (std::string(law) == "pos") {
        EXPECT_LT(overlap, 1e-4);
      }
      // at rest, the projection's tolerance, 1e-3 of the smallest size (a capsule's 1 cm
      // radius); at its peak, a tumbling body's contact separating within the step, left to
      // open by itself, below the 1 %. VEL alone keeps the impacts' h v, about 1.4 mm
      if (projection) {
        EXPECT_LE(overlap, 1e-5 * (1.0 + 1e-9));
        EXPECT_LE(peak, 1e-4);
      }
    }
}

// The same shapes dropped into a triangle-mesh bowl (tests/data/meshes/bowl.stl: a spherical
// cap of radius 0.25 facing its centre (0, 0, 0.25), 240 triangles, open at 70 degrees) stay
// in it, in both schemes, with their overlap bounded as on a plane: VEL keeps at most the
// impact's h v (v from the 0.2 m fall).
TEST_F(InScenesFolder, ShapesStayInATriangleMeshBowl) {
  const std::vector<std::pair<std::string, double>> parts = {
      {"shape: sphere, radius: 0.03", 0.03},
      {"shape: box, size: [0.06, 0.06, 0.06], rpy: [0.3, 0.2, 0.1]", 0.03},
      {"shape: capsule, radius: 0.02, length: 0.08, rpy: [1.2, 0.3, 0]", 0.02}};
  const double h = 1e-3, bound = h * std::sqrt(2.0 * 9.81 * 0.2);
  for (const auto& [part, inner] : parts) {
    const std::string text =
        "dimension: 3\nbodies:\n  - {name: bowl, shape: mesh, file: ../meshes/bowl.stl, "
        "convex: false, fixed: true}\n  - {name: part, " +
        part + ", mass: 1, position: [0.03, 0.02, 0.2]}\ntime: {step: 1.0e-3, end: 1}\n";
    for (const char* scheme : {"moreau-jean", "catching-up"}) {
      SCOPED_TRACE(part + ", " + scheme);
      const SceneFile file =
          loadSceneText(text, "bowl.yaml", {std::string("scheme.name=") + scheme}, {});
      const Scene scene = buildSceneFile(file);
      TimeStepper stepper(scene.model, scene.cmodel, file.run.scheme, scene.forces);
      stepper.reset(0.0, scene.q0, scene.v0);
      double deepest = 0.0, farthest = 0.0;
      int touching = 0;
      for (int k = 0; k < 1000; ++k) {
        const StepStats& stats = stepper.step();
        deepest = std::max(deepest, stats.penetration_max);
        touching += stats.active > 0;
        const Vector3 centre = stepper.q().head<3>();
        farthest = std::max(farthest, (centre - Vector3(0, 0, 0.25)).norm());
      }
      EXPECT_LE(deepest, bound);
      EXPECT_LE(farthest, 0.25 - inner + bound);  // its centre stays inside the cap's sphere
      EXPECT_GT(touching, 700);                   // it landed and stayed in contact
      EXPECT_GT(stepper.q()[2], inner - bound);
    }
  }
}

// package_paths and missing_meshes reach the importer, relative to the scene, and export
// writes them back.
TEST_F(InScenesFolder, UrdfPackagePathsAndMissingMeshesReachTheImporter) {
  const SceneFile file = loadSceneFile("urdf_package.yaml");
  const Scene scene = buildSceneFile(file);
  ASSERT_EQ(scene.model.collisions.size(), 1u);
  EXPECT_EQ(scene.model.collisions[0].type, GeometryType::Box);
  ASSERT_EQ(scene.model.notes.size(), 1u);
  EXPECT_NE(scene.model.notes[0].find("its inertia box collides instead"), std::string::npos);
  const std::string exported = ::testing::TempDir() + "/urdf_package_export.yaml";
  writeSceneFile(file, exported);
  const Scene back = buildSceneFile(loadSceneFile(exported));
  ASSERT_EQ(back.model.collisions.size(), 1u);
  EXPECT_EQ(back.model.collisions[0].box_size, scene.model.collisions[0].box_size);
}

// The sphere rows are compact in both schemes unless a benchmark sets the storage; a scene file
// cannot (a benchmark hook, `sweep run --row-storage`).
TEST(SceneFile, CompactSphereRowsAreAutoUnlessSet) {
  const std::string funnel = std::string(SWEEP_SOURCE_DIR) + "/examples/funnel/funnel.yaml";
  EXPECT_FALSE(loadSceneFile(funnel).run.scheme.compact_sphere_rows.has_value());
  for (const char* key : {"scheme.compact_sphere_rows=true", "scheme.packed_rows=false"})
    EXPECT_THROW(loadSceneFile(funnel, {key}), InputError) << key;
  SchemeSettings s;
  s.scheme = Scheme::MoreauJean;
  EXPECT_TRUE(s.compactSphereRows());
  s.scheme = Scheme::CatchingUp;
  EXPECT_TRUE(s.compactSphereRows());
  s.compact_sphere_rows = false;
  EXPECT_FALSE(s.compactSphereRows());
}

// Loads: a constant force on a free sphere's centre gives a = F / m; a ramp torque gives a
// world-frame spin rate T(t) / I, integrated exactly by the midpoint rule: w(t) = k t^2 /
// (2 I) at the step ends. The sphere is turned at the start, so a torque applied in the
// wrong frame would show. The exported file carries the loads and runs the same.
TEST_F(InScenesFolder, LoadsPushAndTwistABodyInTheWorldFrame) {
  const SceneFile file = loadSceneFile("loads_3d.yaml");
  const Scene scene = buildSceneFile(file);
  ASSERT_TRUE(scene.forces);
  TimeStepper stepper(scene.model, scene.cmodel, file.run.scheme, scene.forces);
  stepper.reset(0.0, scene.q0, scene.v0);
  for (int k = 0; k < 500; ++k) stepper.step();
  const double t = stepper.time();
  EXPECT_NEAR(stepper.v()[1], 4.0 / 2.0 * t, 1e-12);
  Eigen::Quaterniond rotation;
  rotation.coeffs() = stepper.q().segment<4>(3);
  const Vector3 spin = rotation * Vector3(stepper.v().segment<3>(3));
  EXPECT_NEAR(spin.z(), 0.6 * t * t / (2.0 * 0.2), 1e-12);
  EXPECT_NEAR(spin.head<2>().norm(), 0.0, 1e-12);

  const std::string path = ::testing::TempDir() + "/loads_explicit.yaml";
  writeSceneFile(file, path);
  const SceneFile back = loadSceneFile(path);
  ASSERT_EQ(back.spec.loads.size(), 1u);
  EXPECT_EQ(back.spec.loads[0].force, file.spec.loads[0].force);
  EXPECT_EQ(back.spec.loads[0].torque_rate, file.spec.loads[0].torque_rate);
}

TEST(RunSummary, PercentilesAreNearestRank) {
  std::vector<int> values;
  for (int i = 1; i <= 100; ++i) values.push_back(i);
  const Distribution d = distributionOf(values);
  EXPECT_DOUBLE_EQ(d.mean, 50.5);
  EXPECT_DOUBLE_EQ(d.p50, 50);
  EXPECT_DOUBLE_EQ(d.p95, 95);
  EXPECT_DOUBLE_EQ(d.p99, 99);
  EXPECT_DOUBLE_EQ(d.max, 100);
}

TEST_F(InScenesFolder, ARunIsDeterministicAndItsSummaryMatchesItsSteps) {
  const SceneFile file = loadSceneFile("small_box.yaml");
  const Scene scene = buildSceneFile(file);
  RunOptions options;
  options.keep_iterations = true;
  const RunSummary a = runScene(scene, file.run, options);
  const RunSummary b = runScene(scene, file.run, options);
  EXPECT_EQ(a.steps, 200);
  EXPECT_EQ(a.iterations_per_step, b.iterations_per_step);
  EXPECT_EQ(a.penetration_cumulative, b.penetration_cumulative);
  EXPECT_EQ(a.energy_final, b.energy_final);
  ASSERT_EQ(a.iterations_per_step.size(), 200u);
  double sum = 0.0;
  for (int n : a.iterations_per_step) sum += n;
  EXPECT_DOUBLE_EQ(a.iterations.mean, sum / 200.0);
  // the grains settle: energy goes down, and the paddle was pushed into them and removed
  EXPECT_LT(a.energy_final, a.energy_initial);
  EXPECT_GT(a.max_active, 0);
}

}  // namespace
}  // namespace sweep

namespace sweep {
namespace {

// Every kind of 3D body in one file: URDF arm with initial joint state, plane, box, driven
// capsule, generated spheres. It builds what it says and runs with both schemes.
TEST_F(InScenesFolder, ThreeDimensionalSceneWithUrdfBuildsAndRuns) {
  const SceneFile file = loadSceneFile("arm_and_spheres.yaml");
  const Scene scene = buildSceneFile(file);
  const Model& model = scene.model;
  const int arm_dofs = 6, free_bodies = 1 + 8;
  EXPECT_EQ(model.nv, arm_dofs + 6 * free_bodies);
  EXPECT_EQ(model.driven_bodies.size(), 1u);
  const Body& joint2 = model.bodies[model.jointIndex("left_joint2")];
  EXPECT_DOUBLE_EQ(scene.q0[joint2.q_index], 0.5);
  EXPECT_DOUBLE_EQ(scene.v0[model.bodies[model.jointIndex("left_joint1")].v_index], 1.0);
  EXPECT_FALSE(model.limits.empty());
  // the box's quaternion carries its rpy
  const Body& brick = model.bodies[model.bodyIndex("brick")];
  const Eigen::Quaterniond q(scene.q0[brick.q_index + 6], scene.q0[brick.q_index + 3],
                             scene.q0[brick.q_index + 4], scene.q0[brick.q_index + 5]);
  EXPECT_NEAR(q.angularDistance(Eigen::Quaterniond(file.spec.bodies[1 + 8].pose.rotation)), 0.0,
              1e-12);
  for (Scheme scheme : {Scheme::MoreauJean, Scheme::CatchingUp}) {
    RunSettings settings = file.run;
    settings.scheme.scheme = scheme;
    const RunSummary s = runScene(scene, settings, {});
    EXPECT_EQ(s.steps, 200);
    EXPECT_GT(s.max_active, 0) << enumName(scheme);
    EXPECT_TRUE(std::isfinite(s.energy_final));
  }
}

// A mimic joint left unset starts on its coupling (gripper_mimic.urdf: q_r = 2 q_l + 0.01); one
// set off it, or a joint past a limit, is refused at load and in a saved state, naming it.
TEST_F(InScenesFolder, JointsStartInsideTheirLimitsAndOnTheirCouplings) {
  const auto gripper = [](const std::string& joints) {
    return buildSceneFile(loadSceneText(
        "dimension: 3\nurdf:\n  - file: ../urdf/gripper_mimic.urdf\n    joints: " + joints + "\n",
        "gripper.yaml"));
  };
  const Scene neutral = gripper("{}");
  const int left = neutral.model.bodies[neutral.model.jointIndex("finger_left")].q_index;
  const int right = neutral.model.bodies[neutral.model.jointIndex("finger_right")].q_index;
  EXPECT_EQ(neutral.q0[right], 0.01);
  const Scene opened = gripper("{finger_left: 0.01}");
  EXPECT_EQ(opened.q0[right], 2.0 * 0.01 + 0.01);
  EXPECT_NO_THROW(gripper("{finger_left: 0.01, finger_right: 0.03}"));

  // a saved state: the run's own drift passes, a state 0.3 off the coupling does not
  const auto state = [&](double q_left, double q_right) {
    return "vector,index,value\nt,0,0.1\nq,0," + std::to_string(q_left) + "\nq,1," +
           std::to_string(q_right) + "\nv,0,0\nv,1,0\n";
  };
  ASSERT_EQ(left, 0);
  ASSERT_EQ(right, 1);
  EXPECT_NO_THROW(readSavedStateText(state(0.01, 0.0301), "drift.csv", opened, 1e-9));
  try {
    readSavedStateText(state(0.01, 0.08), "offset.csv", opened, 1e-9);
    ADD_FAILURE() << "a state off the coupling was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("offset.csv: joint 'finger_right' is at 0.08 at the "
                                         "saved state's t = 0.1 s, but its mimic coupling"),
              std::string::npos)
        << e.what();
  }
  try {
    readSavedStateText(state(0.05, 0.11), "past.csv", opened, 1e-9);
    ADD_FAILURE() << "a state past a limit was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("past.csv: joint 'finger_left' is at 0.05 m at the "
                                         "saved state's t = 0.1 s, past its upper limit 0.04"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace sweep
