// Issue #8: periodic boundaries, rolling resistance, the powder-bed generator, the layer
// metrics and a reduced spreading pass.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>
#include <utility>
#include <vector>

#include "apps/sweep/layer_output.hpp"
#include "apps/sweep/scene_file.hpp"
#include "framework/error.hpp"
#include "framework/kinematics.hpp"
#include "golden.hpp"
#include "integrators/time_stepper.hpp"
#include "models/powder_bed.hpp"

namespace sweep {
namespace {

SceneFile sceneText(const std::string& text) {
  return loadSceneText(text, "test.yaml");
}

// Two spheres at the two ends of a periodic cell meet through the boundary: one contact, the
// gap of the nearest images, and a normal velocity that is the true approach speed.
TEST(Periodic, SpheresMeetThroughTheBoundary) {
  const SceneFile file = sceneText(R"(
dimension: 3
gravity: [0, 0, 0]
materials: {grain: {density: 1000}}
bodies:
  - {name: a, shape: sphere, radius: 0.1, position: [0.15, 0, 0], velocity: [-1, 0, 0], material: grain}
  - {name: b, shape: sphere, radius: 0.1, position: [1.84, 0, 0], velocity: [1, 0, 0], material: grain}
detection: {periodic: {axis: x, low: 0, high: 2}}
)");
  const Scene scene = buildSceneFile(file);
  Data data(scene.model);
  forwardKinematics(scene.model, data, scene.q0, scene.v0);
  ContactData cdata(scene.model, scene.cmodel);
  detectContacts(scene.model, data, scene.cmodel, cdata, 0.0, 0.2);
  ASSERT_EQ(cdata.contacts.size(), 1u);
  const Contact& c = cdata.contacts[0];
  // centres 0.15 and 1.84 - 2 = -0.16: distance 0.31, radii 0.1 + 0.1
  EXPECT_NEAR(c.gap, 0.31 - 0.2, 1e-14);
  EXPECT_EQ(c.key.feature, 2);  // b's image at -period
  assembleContactJacobian(scene.model, data, scene.cmodel, cdata, 0.0);
  const Vector3 u = cdata.jacobian.relativeVelocity(0, scene.v0);
  EXPECT_NEAR(u.x(), -2.0, 1e-14);  // closing at 2 m/s
  // the lever arm of b's point is taken on b itself: the angular entries of the tangent rows
  // are at most a radius (with the image's position they would be a period)
  for (int k = cdata.jacobian.begin[0]; k < cdata.jacobian.begin[1]; ++k) {
    const int dof = cdata.jacobian.dof[k];
    const bool angular = dof % 6 >= 3;
    if (angular) {
      EXPECT_LE(std::abs(cdata.jacobian.tangent1[k]), 0.1 + 1e-12) << dof;
    }
  }
}

// A head-on collision through the boundary: elastic spheres exchange velocities as they
// would anywhere else, and both stay in the cell.
TEST(Periodic, CollisionThroughTheBoundaryAndWrappedPositions) {
  for (const char* scheme : {"moreau-jean", "catching-up"}) {
    SceneFile file = sceneText(R"(
dimension: 3
gravity: [0, 0, 0]
materials: {grain: {density: 1000}}
contact: {restitution: 1}
bodies:
  - {name: a, shape: sphere, radius: 0.1, position: [0.15, 0, 0], velocity: [-1, 0, 0], material: grain}
  - {name: b, shape: sphere, radius: 0.1, position: [1.84, 0, 0], velocity: [0.5, 0, 0], material: grain}
detection: {periodic: {axis: x, low: 0, high: 2}}
time: {step: 1e-3}
)");
    file.run.scheme.scheme = schemeFromName(scheme);
    const Scene scene = buildSceneFile(file);
    TimeStepper stepper(scene.model, scene.cmodel, file.run.scheme);
    stepper.reset(0.0, scene.q0, scene.v0);
    for (int k = 0; k < 1000; ++k) {
      stepper.step();
      for (int b = 0; b < 2; ++b) {
        const double x = stepper.q()[7 * b];
        ASSERT_GE(x, 0.0) << scheme << " step " << k;
        ASSERT_LT(x, 2.0) << scheme << " step " << k;
      }
    }
    // velocities exchanged (equal masses, e = 1), momentum kept
    EXPECT_NEAR(stepper.v()[0], 0.5, 1e-9) << scheme;
    EXPECT_NEAR(stepper.v()[6], -1.0, 1e-9) << scheme;
  }
}

TEST(Periodic, RefusesWhatItCannotImage) {
  auto error = [](const std::string& text) {
    try {
      buildSceneFile(sceneText(text));
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string head = "dimension: 3\nmaterials: {m: {density: 1000}}\n";
  EXPECT_NE(error(head + R"(bodies:
  - {name: box, shape: box, size: [0.1, 0.1, 0.1], material: m}
  - {name: s, shape: sphere, radius: 0.1, position: [0.5, 0, 0], material: m}
detection: {periodic: {axis: x, low: 0, high: 2}}
)")
                .find("body 'box'"),
            std::string::npos);
  EXPECT_NE(error(head + R"(bodies:
  - {name: s, shape: sphere, radius: 0.1, material: m}
detection: {periodic: {axis: x, low: 0, high: 0.5}}
)")
                .find("three largest grain diameters"),
            std::string::npos);
  EXPECT_NE(error(head + R"(bodies:
  - {name: s, shape: sphere, radius: 0.1, material: m}
detection: {path: fcl, periodic: {axis: x, low: 0, high: 2}}
)")
                .find("needs the analytic detection path"),
            std::string::npos);
  EXPECT_NE(error(head + R"(bodies:
  - {name: s, shape: sphere, radius: 0.1, material: m}
detection: {periodic: {axis: w, low: 0, high: 2}}
)")
                .find("must be x, y or z"),
            std::string::npos);
}

// A ball rolling on a plane under a rolling-resistance torque mu_r R* N (R* = r against a
// plane): it decelerates at mu_r g / (1 + I / (m r^2)) while rolling without slip, then
// stops and stays stopped. Constant forces: exact to the solver tolerance at any h.
TEST(RollingResistance, BallAndDiskDecelerateThenStop) {
  struct Case {
    int dimension;
    double shape_factor;  // I / (m r^2)
  };
  for (const Case& k : {Case{3, 0.4}, Case{2, 0.5}})
    for (const char* scheme : {"moreau-jean", "catching-up"}) {
      const std::string text = k.dimension == 3 ? R"(
dimension: 3
gravity: [0, -9.81, 0]
materials: {steel: {density: 7800}}
contact: {friction: 0.5, rolling_resistance: 0.1}
bodies:
  - {name: floor, shape: plane, fixed: true, normal: [0, 1, 0]}
  - {name: ball, shape: sphere, radius: 0.01, position: [0, 0.01, 0], velocity: [0.1, 0, 0], angular_velocity: [0, 0, -10], material: steel}
time: {step: 1e-3}
)"
                                                : R"(
dimension: 2
gravity: [0, -9.81]
materials: {steel: {density: 7800}}
contact: {friction: 0.5, rolling_resistance: 0.1}
bodies:
  - {name: floor, shape: half_plane, fixed: true, normal: [0, 1]}
  - {name: ball, shape: disk, radius: 0.01, position: [0, 0.01], velocity: [0.1, 0], angular_velocity: -10, material: steel}
time: {step: 1e-3}
)";
      SceneFile file = sceneText(text);
      file.run.scheme.scheme = schemeFromName(scheme);
      file.run.scheme.normal_law = NormalLaw::Pos;
      const Scene scene = buildSceneFile(file);
      TimeStepper stepper(scene.model, scene.cmodel, file.run.scheme);
      stepper.reset(0.0, scene.q0, scene.v0);
      const double a = 0.1 * 9.81 / (1.0 + k.shape_factor);
      for (int step = 0; step < 50; ++step) stepper.step();
      const int spin = k.dimension == 3 ? 5 : 2;  // the angular velocity about z
      EXPECT_NEAR(stepper.v()[0], 0.1 - a * 0.05, 1e-6) << k.dimension << "D " << scheme;
      EXPECT_NEAR(stepper.v()[spin], -stepper.v()[0] / 0.01, 1e-4) << k.dimension << "D " << scheme;
      for (int step = 0; step < 250; ++step) stepper.step();
      EXPECT_NEAR(stepper.v()[0], 0.0, 1e-9) << k.dimension << "D " << scheme;
      EXPECT_NEAR(stepper.v()[spin], 0.0, 1e-7) << k.dimension << "D " << scheme;
    }
}

// A ball set down at rest on top of a spinning roller (the powder-bed roller: a driven capsule
// along z with a prescribed spin), made large so that its top is nearly flat over the test.
// The roller's top moves at s = omega R along -x. Friction drags the ball at mu g while it
// slides; it rolls from t* = 2 s / (7 mu g) on, at 2 s / 7 (a ball on a moving belt, I = 2/5
// m r^2). The spin reaches the contact only through the roller's known velocity.
TEST(Roller, BallOnTheSpinningRollerSlidesThenRollsAtTwoSevenths) {
  const double R = 1.0, r = 0.01, omega = 0.35, mu = 0.5, g = 9.81, h = 1e-4;
  const double s = omega * R, t_stick = 2.0 * s / (7.0 * mu * g);
  for (const char* scheme : {"moreau-jean", "catching-up"}) {
    SceneFile file = sceneText(R"(
dimension: 3
gravity: [0, -9.81, 0]
materials: {steel: {density: 7800}}
contact: {friction: 0.5}
bodies:
  - {name: roller, shape: capsule, radius: 1.0, length: 0.5, motion: {type: velocity, angular_velocity: [0, 0, 0.35]}}
  - {name: ball, shape: sphere, radius: 0.01, position: [0, 1.01, 0], material: steel}
time: {step: 1e-4}
)");
    file.run.scheme.scheme = schemeFromName(scheme);
    const Scene scene = buildSceneFile(file);
    TimeStepper stepper(scene.model, scene.cmodel, file.run.scheme);
    stepper.reset(0.0, scene.q0, scene.v0);
    const int sliding_steps = static_cast<int>(std::lround(0.5 * t_stick / h));
    for (int k = 0; k < sliding_steps; ++k) ASSERT_NE(stepper.step().status, SolverStatus::Failed);
    // sliding: the friction impulse is mu m g h per step (cos of the roller's slope > 1 - 1e-6)
    EXPECT_NEAR(stepper.v()[0], -mu * g * sliding_steps * h, 1e-3 * mu * g * sliding_steps * h)
        << scheme;
    for (int k = sliding_steps; k < static_cast<int>(std::lround(2.0 * t_stick / h)); ++k)
      ASSERT_NE(stepper.step().status, SolverStatus::Failed);
    // rolling, 3 mm down the roller's side by now: gravity along its slope (angle 3e-3) has
    // added about 0.4 % since t*
    EXPECT_NEAR(stepper.v()[0], -2.0 * s / 7.0, 0.01 * 2.0 * s / 7.0) << scheme;
    // no slip at the contact point: the ball's point there moves with the roller's surface
    const Vector3 centre = stepper.q().segment<3>(0);
    const Vector3 n(centre.x(), centre.y(), 0.0);
    const Vector3 normal = n.normalized();
    const Vector3 ball_point =
        stepper.v().segment<3>(0) + stepper.v().segment<3>(3).cross(-r * normal);
    const Vector3 roller_point = Vector3(0, 0, omega).cross(R * normal);
    EXPECT_LT((ball_point - roller_point).norm(), 1e-5 * s) << scheme;
  }
}

// One grain set down over a hollow of the rough plate (four frozen spheres of diameter d on a
// square-ish lattice, pitches d along x and p along z) rests where it touches all four:
// centre height sqrt((r + d/2)^2 - (d/2)^2 - (p/2)^2), below the r of a flat plate. Then the
// rough plate's point: a grain rolling at 5 cm/s, which a flat plate lets roll 1.7 mm against
// its rolling resistance, is stopped by the bumps within a fraction of that.
TEST(RoughPlate, GrainRestsInAHollowAndBumpsStopARollingGrain) {
  auto scene = [](const char* plate) {
    return sceneText(std::string(R"(
dimension: 3
gravity: [0, -9.81, 0]
generators:
  - {type: powder_bed, count: 1, sizes: {diameters: [40e-6], mass_fractions: [1]}, settle_time: 1, plate: )") +
                     plate + R"(}
scheme: {name: moreau-jean, normal_law: vel}
time: {step: 1e-5}
)");
  };
  // the lattice, from the generated plate
  SceneFile rough = scene("rough");
  const BodySpec* first = nullptr;
  const BodySpec* second = nullptr;
  for (const BodySpec& b : rough.spec.bodies) {
    if (b.name == "plate_sphere0") first = &b;
    if (b.name == "plate_sphere1") second = &b;
  }
  ASSERT_TRUE(first && second);
  const double d = 2.0 * first->shape.radius;
  const double pitch_z = second->pose.translation.z() - first->pose.translation.z();
  const double r = rough.spec.bodies.back().shape.radius;
  ASSERT_EQ(r, 20e-6);
  ASSERT_EQ(d, 40e-6);  // one grain: the plate's spheres take its diameter
  const double x0 = first->pose.translation.x();
  // a hollow 3 mm along, clear of the blade, gate and fence; between z rows 0 and 1
  const Vector3 hollow(x0 + 75.5 * d, 0.0, first->pose.translation.z() + 1.5 * pitch_z);
  const double rest =
      std::sqrt(std::pow(r + 0.5 * d, 2) - std::pow(0.5 * d, 2) - std::pow(0.5 * pitch_z, 2));

  auto run = [](SceneFile& file, double seconds) {
    const Scene built = buildSceneFile(file);
    TimeStepper stepper(built.model, built.cmodel, file.run.scheme);
    stepper.reset(0.0, built.q0, built.v0);
    const long steps = std::lround(seconds / file.run.scheme.h);
    for (long k = 0; k < steps; ++k) EXPECT_NE(stepper.step().status, SolverStatus::Failed);
    return std::make_pair(Vector3(stepper.q().segment<3>(0)), Vector3(stepper.v().segment<3>(0)));
  };

  rough.spec.bodies.back().pose.translation = hollow + Vector3(0.0, rest + 5e-6, 0.0);
  const auto [settled, settled_v] = run(rough, 0.005);
  // at rest in contact with four spheres, the gap closed to round-off (VEL leaves no overlap
  // at rest; it is h times the last small impact speed)
  EXPECT_NEAR(settled.y(), rest, 1e-9);
  EXPECT_NEAR(settled.x(), hollow.x(), 1e-9);
  EXPECT_NEAR(settled.z(), hollow.z(), 1e-9);
  EXPECT_LT(settled_v.norm(), 1e-6);

  // rolling without slip from the start: along x, spin about -z
  const double speed = 0.05;
  auto roll = [&](SceneFile& file, double height) {
    BodySpec& grain = file.spec.bodies.back();
    grain.pose.translation = Vector3(hollow.x(), height, hollow.z());
    grain.velocity = Vector3(speed, 0.0, 0.0);
    grain.angular_velocity = Vector3(0.0, 0.0, -speed / r);
    return run(file, 0.08);
  };
  SceneFile flat = scene("flat");
  const auto [flat_end, flat_v] = roll(flat, r);
  SceneFile rough_roll = scene("rough");
  const auto [rough_end, rough_v] = roll(rough_roll, rest);
  // flat: decelerates at mu_r g / (1 + 2/5) while it rolls, then stops
  const double flat_distance = speed * speed / (2.0 * 0.1 * 9.81 / 1.4);
  EXPECT_NEAR(flat_end.x() - hollow.x(), flat_distance, 1e-4 * flat_distance);
  EXPECT_LT(flat_v.norm(), 1e-6);
  // rough: over a few bumps (6 pitches with this seed), at rest in a hollow, not through it
  EXPECT_LT(std::abs(rough_end.x() - hollow.x()), 0.25 * flat_distance);
  EXPECT_LT(rough_v.norm(), 1e-6);
  EXPECT_NEAR(rough_end.y(), rest, 0.01 * r);
}

TEST(LayerMetrics, OneSphereAndOneAcrossThePeriodicEdge) {
  LayerWindow w;
  w.x_min = 0.0;
  w.x_max = 1e-3;
  w.z_min = 0.0;
  w.z_max = 0.5e-3;
  w.gap = 100e-6;
  w.cell = 0.5e-3;
  w.resolution = 0.5e-6;
  const double r = 20e-6;
  const double area = 1e-3 * 0.5e-3;
  // a sphere on the plate in the middle, and one cut by the periodic edge z = 0
  const std::vector<Vector3> centers = {Vector3(0.5e-3, r, 0.25e-3), Vector3(0.2e-3, r, 0.0)};
  const std::vector<double> radii = {r, r};
  const LayerMetrics m = layerMetrics(centers, radii, w);
  const double volume = 4.0 / 3.0 * M_PI * r * r * r;
  EXPECT_NEAR(m.packing_fraction, 2.0 * volume / (area * w.gap), 2e-3 * m.packing_fraction);
  EXPECT_NEAR(m.coverage, 2.0 * M_PI * r * r / area, 2e-3 * m.coverage);
  EXPECT_NEAR(m.solid_thickness, 2.0 * volume / area, 2e-3 * m.solid_thickness);
  EXPECT_NEAR(m.highest_top, 2.0 * r, 1e-15);
  EXPECT_EQ(m.cells, 2);
  EXPECT_EQ(m.particles, 2);
  // a sphere above the gap counts in the thickness but not in the packing
  const LayerMetrics high = layerMetrics({Vector3(0.5e-3, w.gap + 2.0 * r, 0.25e-3)}, {r}, w);
  EXPECT_EQ(high.packing_fraction, 0.0);
  EXPECT_NEAR(high.solid_thickness, volume / area, 2e-3 * high.solid_thickness);
}

// A fixed sphere centred on the plate (one bump of a rough plate) holds its upper half in the
// gap; the grains' packing over the volume left free is the packing over (1 - that share).
// Its copy one period away in z (a rough plate's edge rows have such copies) is not counted.
TEST(LayerMetrics, FixedSpheresLeaveLessVolumeToPack) {
  const SceneFile file = sceneText(R"(
dimension: 3
gravity: [0, -9.81, 0]
materials: {grain: {density: 4430}}
bodies:
  - {name: bump, shape: sphere, radius: 20.0e-6, position: [0.25e-3, 0, 0.25e-3], fixed: true}
  - {name: bump_copy, shape: sphere, radius: 20.0e-6, position: [0.25e-3, 0, -0.25e-3], fixed: true}
  - {name: grain, shape: sphere, radius: 20.0e-6, position: [0.75e-3, 20.0e-6, 0.25e-3], velocity: [0, 0.3, 0.4], angular_velocity: [0, 0, 1000], material: grain}
output: {layer: {x_min: 0, x_max: 1.0e-3, z_min: 0, z_max: 0.5e-3, gap: 100.0e-6, resolution: 0.5e-6}}
)");
  const Scene scene = buildSceneFile(file);
  const LayerMetrics m = measureLayer(scene, scene.q0, *file.run.output.layer, &scene.v0);
  const double r = 20e-6, window = 1e-3 * 0.5e-3 * 100e-6;
  const double ball = 4.0 / 3.0 * M_PI * r * r * r;
  // 2e-3: the column discretisation of a sphere at 0.5 um columns, as in the test above
  EXPECT_NEAR(m.packing_fraction, ball / window, 2e-3 * m.packing_fraction);
  EXPECT_NEAR(m.fixed_fraction, 0.5 * ball / window, 2e-3 * m.fixed_fraction);
  EXPECT_DOUBLE_EQ(m.free_volume_packing_fraction, m.packing_fraction / (1.0 - m.fixed_fraction));
  EXPECT_EQ(m.particles, 1);                     // the bump is not a grain
  EXPECT_NEAR(m.highest_top_speed, 0.5, 1e-12);  // the grain's, its spin adding nothing
}

TEST(PowderBed, SizesFollowTheMassFractions) {
  PowderBedParameters p;
  p.count = 20000;
  const std::vector<double> d = powderDiameters(p);
  std::vector<double> mass(3, 0.0);
  for (double x : d)
    for (int i = 0; i < 3; ++i)
      if (x == p.diameters[i]) mass[i] += x * x * x;
  const double total = std::accumulate(mass.begin(), mass.end(), 0.0);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(mass[i] / total, p.mass_fractions[i], 0.02) << i;
  p.sizes = PowderBedParameters::Sizes::LogNormal;
  for (double x : powderDiameters(p)) {
    ASSERT_GE(x, p.d_min);
    ASSERT_LE(x, p.d_max);
  }
  p.travel = 10e-3;
  EXPECT_THROW(powderBed(p), InputError);
}

// copies_across: the same heap repeated across z, one width apart, in a period that many widths
// wide, with the rough plate's rows continuing across the seams; one copy is the plain bed.
TEST(PowderBed, CopiesAcrossRepeatTheHeapOneWidthApart) {
  PowderBedParameters p;
  p.count = 120;
  p.rough_plate = true;
  const SceneSpec one = powderBed(p);
  p.copies_across = 3;
  const SceneSpec three = powderBed(p);
  EXPECT_DOUBLE_EQ(one.detection.periodic.high, p.width);
  EXPECT_DOUBLE_EQ(three.detection.periodic.high, 3.0 * p.width);
  EXPECT_DOUBLE_EQ(defaultLayerWindow(p).z_max, 3.0 * p.width);
  auto grains = [](const SceneSpec& spec) {
    std::vector<const BodySpec*> out;
    for (const BodySpec& b : spec.bodies)
      if (b.kind == BodySpec::Kind::Dynamic) out.push_back(&b);
    return out;
  };
  auto plate_spheres = [](const SceneSpec& spec) {
    std::vector<Vector3> out;
    for (const BodySpec& b : spec.bodies)
      if (b.kind == BodySpec::Kind::Fixed && b.shape.type == ShapeType::Sphere)
        out.push_back(b.pose.translation);
    return out;
  };
  const auto g1 = grains(one), g3 = grains(three);
  ASSERT_EQ(g1.size(), 120u);
  ASSERT_EQ(g3.size(), 360u);
  for (int copy = 0; copy < 3; ++copy)
    for (int i = 0; i < 120; ++i) {
      const BodySpec& a = *g1[i];
      const BodySpec& b = *g3[copy * 120 + i];
      ASSERT_EQ(b.shape.radius, a.shape.radius) << copy << " " << i;
      const Vector3 shift = b.pose.translation - a.pose.translation;
      ASSERT_EQ(shift.x(), 0.0);
      ASSERT_EQ(shift.y(), 0.0);
      ASSERT_NEAR(shift.z(), copy * p.width, 1e-15);
      ASSERT_EQ(b.name, "p" + std::to_string(copy * 120 + i));
    }
  // the rough plate: the one-copy rows (one past each boundary) continue at the same pitch
  const auto r1 = plate_spheres(one), r3 = plate_spheres(three);
  ASSERT_FALSE(r1.empty());
  double z1_max = 0.0, z3_max = 0.0;
  for (const Vector3& c : r1) z1_max = std::max(z1_max, c.z());
  for (const Vector3& c : r3) z3_max = std::max(z3_max, c.z());
  EXPECT_NEAR(z3_max - z1_max, 2.0 * p.width, 1e-12);
  EXPECT_GT(r3.size(), 2 * r1.size());
  p.copies_across = 0;
  EXPECT_THROW(powderBed(p), InputError);
}

// A reduced pass (300 spheres, 1.2 mm of travel, Jean-Moreau): nothing is lost, nothing stays
// above the gap behind the blade, and the layer is sparse.
TEST(PowderBed, ReducedPassKeepsEveryGrainAndLeavesNothingAboveTheGap) {
  SceneFile file = sceneText(R"(
dimension: 3
gravity: [0, -9.81, 0]
generators:
  - {type: powder_bed, count: 300, length: 2.4e-3, travel: 1.2e-3, heap_length: 0.5e-3, settle_time: 0.015}
scheme: {name: moreau-jean, normal_law: vel}
time: {step: 1e-5, end: 0.027}
output: {layer: {x_min: 0.4e-3, x_max: 1.2e-3}}
)");
  const Scene scene = buildSceneFile(file);
  TimeStepper stepper(scene.model, scene.cmodel, file.run.scheme);
  stepper.reset(0.0, scene.q0, scene.v0);
  const long steps = std::lround(file.run.t_end / file.run.scheme.h);
  // no grain ever moves faster than a fall from the blade's top (0.18 m/s) plus a rebound:
  // the POS law with e = 0.5 launched grains at several m/s here (docs/powder_bed.md)
  double fastest = 0.0;
  for (long k = 0; k < steps; ++k) {
    ASSERT_NE(stepper.step().status, SolverStatus::Failed);
    for (int b = 0; b < scene.model.nv / 6; ++b)
      fastest = std::max(fastest, stepper.v().segment<3>(6 * b).norm());
  }
  EXPECT_LT(fastest, 0.5);
  const LayerMetrics layer = measureLayer(scene, stepper.q(), *file.run.output.layer);
  const int n = scene.model.nv / 6;
  ASSERT_EQ(n, 300);
  for (int b = 0; b < n; ++b) {
    const Vector3 x = stepper.q().segment<3>(7 * b);
    EXPECT_GT(x.x(), 0.0) << b;
    EXPECT_LT(x.x(), 2.4e-3) << b;
    EXPECT_GT(x.y(), 0.0) << b;  // above the plate (radius 15-25 um, penetration << 1 um)
    EXPECT_GE(x.z(), 0.0) << b;
    EXPECT_LT(x.z(), 0.4e-3) << b;
  }
  // the blade's edge is 100 um up: the tallest grain behind it reaches no higher (1 um for
  // the overlap VEL leaves, about h times an impact speed)
  EXPECT_LT(layer.highest_top, 100e-6 + 1e-6);
  EXPECT_GT(layer.packing_fraction, 0.05);
  EXPECT_LT(layer.packing_fraction, 0.5);
}

// Scheme B reads compact sphere rows directly in every solver that reads packed rows: its
// stage sweeps (NLGS with NNCG), their residuals, the projection on the closed normals (IQS
// leaves a bias on closed rows) and MPRGP / APGD's operators. The reduced bed with friction
// and rolling resistance, its heap formed over 500 steps from the generator's lattice, then
// two steps from that state on each storage, the stages at 1e-10: the compact rows give the
// body-form rows' velocities to the stages' tolerance, in both solver families (measured:
// 4e-13 of the largest speed for NLGS, 2e-9 for MPRGP / APGD, whose iterates stop elsewhere
// in the heap's redundant impulses; a 0.1 % error in the compact rows' coupling of rolling
// and tangential impulses gives 1.3e-9 under NLGS). Over more steps the falling heap
// amplifies any round-off a hundredfold per 50 steps.
TEST(PowderBed, TheStaggeredSchemeOnCompactSphereRowsSolvesAsOnBodyFormRows) {
  const std::string scene_path =
      std::string(SWEEP_SOURCE_DIR) + "/examples/powder_bed/powder_bed_reduced.yaml";
  const std::vector<std::string> staggered = {"scheme.name=catching-up", "scheme.normal_law=iqs"};
  const SceneFile heap_file = loadSceneFile(scene_path, staggered);
  const Scene scene = buildSceneFile(heap_file);
  ASSERT_TRUE(scene.cmodel.rolling);
  TimeStepper heap(scene.model, scene.cmodel, heap_file.run.scheme);
  heap.reset(0.0, scene.q0, scene.v0);
  for (int k = 0; k < 500; ++k) heap.step();
  const std::pair<const char*, double> solvers[] = {{"auto", 1e-11}, {"mprgp", 1e-8}};
  for (const auto& [solver, bound] : solvers) {
    std::vector<std::string> overrides = staggered;
    for (const char* stage : {"normal_stage", "friction_stage"}) {
      const std::string key = std::string("scheme.") + stage;
      overrides.push_back(key + ".solver=" + solver);
      overrides.push_back(key + ".tolerance=1e-10");
      overrides.push_back(key + ".max_iterations=20000");
    }
    SchemeSettings s = loadSceneFile(scene_path, overrides).run.scheme;
    std::vector<VectorX> end;
    for (const bool compact : {false, true}) {
      s.compact_sphere_rows = compact;
      TimeStepper stepper(scene.model, scene.cmodel, s);
      stepper.reset(heap.time(), heap.q(), heap.v());
      for (int k = 0; k < 2; ++k) ASSERT_FALSE(stepper.step().cap_hit) << solver;
      int closed = 0;
      for (const Vector3& P : stepper.impulses()) closed += P.x() > 0.0 ? 1 : 0;
      EXPECT_GT(closed, 300) << solver;  // a heap in contact, not grains in flight
      EXPECT_EQ(stepper.problem().spheres3d.empty(), !compact) << solver;
      end.push_back(stepper.v());
    }
    const double difference = (end[1] - end[0]).cwiseAbs().maxCoeff();
    EXPECT_LT(difference, bound * end[0].cwiseAbs().maxCoeff()) << solver;
    EXPECT_GT(difference, 0.0) << solver;  // two storages, not one run twice
  }
}

// Golden regression of an adhesive powder run (issue #50): the reduced bed with the calibrated
// surface energy of Ti-6Al-4V (0.1 mJ/m^2), 500 steps of 1e-5 s from the generator's lattice,
// each scheme, final positions against the stored ones (SWEEP_UPDATE_GOLDEN=1 rewrites them;
// say why in the commit). Tolerance 1e-12 m (1e-7 of the smallest radius): the same build
// gives the same bits; any change of the law, a solver or the detection moves grains by more.
class AdhesiveGolden : public ::testing::TestWithParam<std::string> {};

TEST_P(AdhesiveGolden, FinalPositionsMatchTheStoredRun) {
  const SceneFile file =
      loadSceneFile(std::string(SWEEP_SOURCE_DIR) + "/examples/powder_bed/powder_bed_reduced.yaml",
                    {"scheme.name=" + GetParam(), "generators[0].surface_energy=1e-4"});
  const Scene scene = buildSceneFile(file);
  ASSERT_TRUE(scene.cmodel.adhesive());
  TimeStepper stepper(scene.model, scene.cmodel, file.run.scheme);
  stepper.reset(0.0, scene.q0, scene.v0);
  for (int k = 0; k < 500; ++k) stepper.step();
  // the law acts: some contacts end the run in tension
  int pulling = 0;
  for (const Vector3& P : stepper.impulses()) pulling += P.x() < 0.0 ? 1 : 0;
  EXPECT_GT(pulling, 0);

  const std::string path =
      std::string(SWEEP_TEST_DATA) + "/golden/powder_adhesive_500_" + GetParam() + ".csv";
  if (test::rewriteGolden(path, stepper.q())) GTEST_SKIP() << "rewrote " << path;
  // orientations: compared through the positions they carry
  const double worst = test::goldenDifference(path, stepper.q(), [](int i) { return i % 7 < 3; });
  EXPECT_LT(worst, 1e-12);
}

INSTANTIATE_TEST_SUITE_P(Schemes, AdhesiveGolden,
                         ::testing::Values(std::string("moreau-jean"), std::string("catching-up")),
                         [](const auto& param_info) {
                           return param_info.param == "moreau-jean" ? "MoreauJean" : "CatchingUp";
                         });

}  // namespace
}  // namespace sweep
