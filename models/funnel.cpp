#include "models/funnel.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "framework/error.hpp"

namespace sweep {

namespace {

void require(bool ok, const std::string& field, double value, const std::string& rule) {
  if (ok) return;
  std::ostringstream s;
  s << "hall_funnel: " << field << ": " << rule << ", got " << value;
  throw InputError(s.str());
}

Pose planarPose(double x, double y) {
  Pose p;
  p.translation = Vector3(x, y, 0.0);
  return p;
}

}  // namespace

void FunnelParameters::validate() const {
  require(count >= 1, "count", count, "must be >= 1");
  require(radius_mean > 0.0 && std::isfinite(radius_mean), "radius_mean", radius_mean,
          "must be > 0");
  require(radius_std >= 0.0 && radius_std < 0.3, "radius_std", radius_std,
          "must be in [0, 0.3) (a fraction of the mean)");
  require(density > 0.0 && std::isfinite(density), "density", density, "must be > 0");
  require(friction >= 0.0 && std::isfinite(friction), "friction", friction, "must be >= 0");
  require(restitution >= 0.0 && restitution <= 1.0, "restitution", restitution,
          "must be in [0, 1]");
  require(std::isfinite(gravity), "gravity", gravity, "must be finite");
  require(included_angle > 0.0 && included_angle < 180.0, "included_angle", included_angle,
          "must be in (0, 180) degrees");
  require(orifice > 0.0 && std::isfinite(orifice), "orifice", orifice, "must be > 0");
  require(std::isfinite(shutter_time), "shutter_time", shutter_time, "must be finite");
  require(lattice_spacing >= 1.0 && lattice_spacing < 10.0, "lattice_spacing", lattice_spacing,
          "must be in [1, 10)");
}

SceneSpec hallFunnel(const FunnelParameters& p) {
  p.validate();
  const std::vector<double> radii = sampleRadii(
      RadiusDistribution::normal(p.radius_mean, p.radius_std * p.radius_mean), p.count, p.seed);
  const double largest = *std::max_element(radii.begin(), radii.end());
  const double pitch = 2.0 * largest * p.lattice_spacing;
  const double slope = std::tan(0.5 * p.included_angle * M_PI / 180.0);  // dx per dy of a wall

  // lattice rows inside the cone: a row at height y holds the disks whose centres keep one
  // pitch/2 off both walls (measured horizontally, which is conservative)
  // the first row with room for a centre, in closed form: a near-zero angle over a narrow
  // orifice would otherwise be searched row by row (for ever)
  const double wall_offset = 0.5 * pitch / std::cos(std::atan(slope));
  const double first_row =
      std::max(0.0, std::floor((wall_offset - 0.5 * p.orifice) / (slope * pitch) - 0.5));
  require(first_row < 1e6, "included_angle", p.included_angle,
          "leaves no room for a grain over the orifice " + formatValue(p.orifice) +
              " m within 10^6 lattice rows: widen the angle or the orifice");
  std::vector<Vector3> centres;
  for (long row = static_cast<long>(first_row); static_cast<int>(centres.size()) < p.count; ++row) {
    const double y = pitch * (0.5 + row);
    const double half_width = 0.5 * p.orifice + y * slope - wall_offset;
    if (half_width < 0.0) continue;
    // in double first: tiny grains in a wide cone fit more per row than an int holds
    const double fits = std::floor(2.0 * half_width / pitch) + 1.0;
    const int fit = fits < static_cast<double>(p.count) ? static_cast<int>(fits) : p.count;
    // stagger odd rows by a quarter pitch, where the row has room, so that columns do not
    // stack exactly
    const bool room = (fit - 1) * pitch + 0.5 * pitch <= 2.0 * half_width;
    const double shift = (row % 2 == 1 && room) ? 0.25 * pitch : 0.0;
    const double first = -0.5 * (fit - 1) * pitch + shift;
    for (int k = 0; k < fit && static_cast<int>(centres.size()) < p.count; ++k)
      centres.emplace_back(first + k * pitch, y, 0.0);
  }
  const double top = centres.back().y() + pitch;

  SceneSpec spec;
  spec.source = "hall_funnel";
  spec.dimension = 2;
  spec.gravity = Vector3(0.0, -p.gravity, 0.0);
  spec.materials = {{"steel", p.density}, {"wall", 0.0}};
  // pair laws rather than the default law, so that the funnel can join a larger scene
  spec.laws = {{"steel", "steel", {p.friction, p.restitution}},
               {"steel", "wall", {p.friction, p.restitution}}};

  const double rim = 0.5 * p.orifice + top * slope;
  auto wall = [&](const std::string& name, double x0, double x1) {
    BodySpec b;
    b.name = name;
    b.kind = BodySpec::Kind::Fixed;
    b.material = "wall";
    b.shape = Shape::segment(Vector2(x0, 0.0), Vector2(x1, top));
    spec.bodies.push_back(b);
  };
  wall("wall_left", -0.5 * p.orifice, -rim);
  wall("wall_right", 0.5 * p.orifice, rim);
  BodySpec shutter;
  shutter.name = "shutter";
  shutter.kind = BodySpec::Kind::Driven;
  shutter.material = "wall";
  // a little wider than the orifice so that no disk slips past its ends
  shutter.shape = Shape::segment(Vector2(-0.5 * p.orifice - largest, 0.0),
                                 Vector2(0.5 * p.orifice + largest, 0.0));
  shutter.motion.kind = MotionSpec::Kind::Fixed;
  shutter.motion.removal_time = p.shutter_time;
  spec.bodies.push_back(shutter);

  for (int i = 0; i < p.count; ++i) {
    BodySpec b;
    b.name = "disk" + std::to_string(i);
    b.shape = Shape::disk(radii[i]);
    b.material = "steel";
    b.pose = planarPose(centres[i].x(), centres[i].y());
    spec.bodies.push_back(b);
  }
  return spec;
}

}  // namespace sweep
