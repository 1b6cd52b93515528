// The scene file's generators (scene_parser.hpp): lattices, the Hall funnel, the powder bed,
// and the memory their bodies will take, checked before any is made.
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "apps/sweep/scene_parser.hpp"
#include "framework/error.hpp"
#include "framework/memory.hpp"
#include "models/funnel.hpp"
#include "models/powder_bed.hpp"

namespace sweep {

RadiusDistribution SceneParser::parseRadius(const YamlField& f) {
  if (f.isScalar()) return RadiusDistribution::constant(f.positive());
  f.requireMap();
  if (f.has("mean")) {
    f.allowOnly({"mean", "std"});
    const double std = f.nonNegative("std", 0.0);
    const double mean = f["mean"].positive();
    if (!(mean - 3.0 * std > 0.0)) f["std"].fail("must be below mean / 3 (radii stay > 0)");
    return RadiusDistribution::normal(mean, std);
  }
  f.allowOnly({"min", "max"});
  const double low = f["min"].positive(), high = f["max"].positive();
  if (!(high >= low)) f["max"].fail("must be >= min");
  return RadiusDistribution::uniform(low, high);
}

void SceneParser::parseGenerators(const YamlField& generators) {
  generators.requireSequence();
  for (std::size_t i = 0; i < generators.size(); ++i) {
    const YamlField g = generators.at(i);
    g.requireMap();
    const std::string type = g["type"].text();
    if (type == "hall_funnel")
      hallFunnelGenerator(g);
    else if (type == "powder_bed")
      powderBedGenerator(g);
    else if (type == "disks" || type == "spheres")
      latticeGenerator(g, type == "disks");
    else
      g["type"].fail("must be disks, spheres, hall_funnel or powder_bed");
  }
}

void SceneParser::latticeGenerator(const YamlField& g, bool disks) {
  g.allowOnly(
      {"type", "count", "name", "radius", "region", "spacing", "seed", "material", "velocity"});
  const int dim = out_.spec.dimension;
  if (disks != (dim == 2))
    g["type"].fail(std::string("does not fit a ") + std::to_string(dim) + "D scene");
  const long count = g["count"].integer();
  if (count < 1 || count > max_count_) g["count"].fail("must be in [1, " + countLimit() + "]");
  planBodies(g["count"], count);
  const RadiusDistribution distribution = parseRadius(g["radius"]);
  const long seed = g.integer("seed", 1);
  if (seed < 0 || seed > 4294967295L) g["seed"].fail("must be in [0, 2^32)");
  const std::vector<double> radii =
      sampleRadii(distribution, static_cast<int>(count), static_cast<std::uint32_t>(seed));
  const double spacing = g.number("spacing", 1.1);
  if (!(spacing >= 1.0)) g["spacing"].fail("must be >= 1 (grains may not overlap)");
  const YamlField region = g["region"];
  region.allowOnly({"min", "max"});
  const Vector3 low = region["min"].vector(dim), high = region["max"].vector(dim);
  const double pitch = 2.0 * *std::max_element(radii.begin(), radii.end()) * spacing;
  long across[3] = {1, 1, 1};
  for (int k = 0; k < dim; ++k) {
    const double fits = std::floor((high[k] - low[k]) / pitch);
    if (!(fits >= 1.0))
      region.fail("is narrower than one lattice pitch (" + formatValue(pitch) + ")");
    // no more than `count` along any axis is ever needed (and the product cannot overflow)
    across[k] = fits < static_cast<double>(count) ? static_cast<long>(fits) : count;
  }
  const long capacity = across[0] * across[1] * across[2];
  if (capacity < count)
    g["count"].fail("the region holds only " + std::to_string(capacity) +
                    " grains at this spacing");
  const std::string material = g.text("material", "");
  if (!material.empty()) requireMaterial(g["material"], material);
  const Vector3 velocity = g.has("velocity") ? g["velocity"].vector(dim) : Vector3::Zero();
  const std::string prefix = g.text("name", disks ? "disk" : "sphere");
  // fill x first, then z (3D), then y upwards: the lattice grows from the floor
  for (long i = 0; i < count; ++i) {
    BodySpec b;
    b.name = prefix + std::to_string(i);
    b.shape = disks ? Shape::disk(radii[i]) : Shape::sphere(radii[i]);
    b.material = material;
    const long ix = i % across[0];
    const long iz = dim == 3 ? (i / across[0]) % across[2] : 0;
    const long iy = dim == 3 ? i / (across[0] * across[2]) : i / across[0];
    b.pose.translation = low + pitch * Vector3(0.5 + ix, 0.5 + iy, dim == 3 ? 0.5 + iz : 0.0);
    if (dim == 2) b.pose.translation.z() = 0.0;
    b.velocity = velocity;
    out_.spec.bodies.push_back(b);
  }
}

void SceneParser::hallFunnelGenerator(const YamlField& g) {
  g.allowOnly({"type", "count", "radius_mean", "radius_std", "density", "friction", "restitution",
               "included_angle", "orifice", "shutter_time", "lattice_spacing", "seed"});
  if (out_.spec.dimension != 2) g["type"].fail("is a 2D generator");
  FunnelParameters p;
  const long count = g.integer("count", p.count);
  if (count > max_count_) g["count"].fail("must be <= " + countLimit());
  if (count > 0) planBodies(g["count"], count);
  p.count = static_cast<int>(count);
  p.radius_mean = g.number("radius_mean", p.radius_mean);
  p.radius_std = g.number("radius_std", p.radius_std);
  p.density = g.number("density", p.density);
  p.friction = g.number("friction", p.friction);
  p.restitution = g.number("restitution", p.restitution);
  p.included_angle = g.number("included_angle", p.included_angle);
  p.orifice = g.number("orifice", p.orifice);
  p.shutter_time = g.number("shutter_time", p.shutter_time);
  p.lattice_spacing = g.number("lattice_spacing", p.lattice_spacing);
  const long seed = g.integer("seed", p.seed);
  if (seed < 0 || seed > 4294967295L) g["seed"].fail("must be in [0, 2^32)");
  p.seed = static_cast<std::uint32_t>(seed);
  addGenerated(g, [&] { return hallFunnel(p); });
}

// Runs a scene builder for generator g and merges its materials, laws and bodies. The
// builder names the parameter in its errors; this adds where it came from.
template <class Build>
SceneSpec SceneParser::addGenerated(const YamlField& g, Build&& build) {
  SceneSpec made;
  try {
    made = build();
  } catch (const InputError& e) {
    throw InputError(path_ + ": " + g.path() + ": " + e.what());
  }
  for (const MaterialSpec& m : made.materials) addMaterial(m, g);
  out_.spec.laws.insert(out_.spec.laws.end(), made.laws.begin(), made.laws.end());
  out_.spec.bodies.insert(out_.spec.bodies.end(), made.bodies.begin(), made.bodies.end());
  return made;
}

void SceneParser::powderBedGenerator(const YamlField& g) {
  g.allowOnly({"type",
               "count",
               "sizes",
               "density",
               "friction",
               "restitution",
               "rolling_resistance",
               "surface_energy",
               "adhesion_range",
               "length",
               "width",
               "height",
               "gap",
               "blade_thickness",
               "blade_start",
               "speed",
               "travel",
               "heap_length",
               "settle_time",
               "lattice_spacing",
               "spreader",
               "roller_radius",
               "roller_spin",
               "plate",
               "copies_across",
               "seed"});
  if (out_.spec.dimension != 3) g["type"].fail("is a 3D generator");
  if (powder_layer_) g["type"].fail("a scene holds one powder bed");
  PowderBedParameters p;
  const long count = g.integer("count", p.count);
  if (count < 1 || count > max_count_) g["count"].fail("must be in [1, " + countLimit() + "]");
  p.count = static_cast<int>(count);
  const long copies = g.integer("copies_across", 1);
  if (copies < 1 || copies > max_count_ / count)
    g["copies_across"].fail("must be >= 1, with count * copies_across <= " + countLimit());
  planBodies(g.has("copies_across") ? g["copies_across"] : g["count"], count * copies);
  p.copies_across = static_cast<int>(copies);
  if (g.has("sizes")) {
    const YamlField sizes = g["sizes"];
    sizes.requireMap();
    const std::string kind = sizes.text("kind", "discrete");
    if (kind == "discrete") {
      sizes.allowOnly({"kind", "diameters", "mass_fractions"});
      p.sizes = PowderBedParameters::Sizes::Discrete;
      p.diameters = sizes["diameters"].numbers();
      p.mass_fractions = sizes["mass_fractions"].numbers();
    } else if (kind == "lognormal") {
      sizes.allowOnly({"kind", "d50", "geometric_std", "d_min", "d_max"});
      p.sizes = PowderBedParameters::Sizes::LogNormal;
      p.d50 = sizes.number("d50", p.d50);
      p.geometric_std = sizes.number("geometric_std", p.geometric_std);
      p.d_min = sizes.number("d_min", p.d_min);
      p.d_max = sizes.number("d_max", p.d_max);
    } else {
      sizes["kind"].fail("must be discrete or lognormal");
    }
  }
  for (const auto& [key, field] :
       std::vector<std::pair<const char*, double*>>{{"density", &p.density},
                                                    {"friction", &p.friction},
                                                    {"restitution", &p.restitution},
                                                    {"rolling_resistance", &p.rolling_resistance},
                                                    {"surface_energy", &p.surface_energy},
                                                    {"adhesion_range", &p.adhesion_range},
                                                    {"length", &p.length},
                                                    {"width", &p.width},
                                                    {"height", &p.height},
                                                    {"gap", &p.gap},
                                                    {"blade_thickness", &p.blade_thickness},
                                                    {"blade_start", &p.blade_start},
                                                    {"speed", &p.speed},
                                                    {"travel", &p.travel},
                                                    {"heap_length", &p.heap_length},
                                                    {"settle_time", &p.settle_time},
                                                    {"lattice_spacing", &p.lattice_spacing},
                                                    {"roller_radius", &p.roller_radius},
                                                    {"roller_spin", &p.roller_spin}})
    *field = g.number(key, *field);
  const std::string spreader = g.text("spreader", "blade");
  if (spreader != "blade" && spreader != "roller") g["spreader"].fail("must be blade or roller");
  p.roller = spreader == "roller";
  const std::string plate = g.text("plate", "flat");
  if (plate != "flat" && plate != "rough") g["plate"].fail("must be flat or rough");
  p.rough_plate = plate == "rough";
  const long seed = g.integer("seed", 1);
  if (seed < 0 || seed > 4294967295L) g["seed"].fail("must be in [0, 2^32)");
  p.seed = static_cast<std::uint32_t>(seed);
  // the cheap checks and the rough plate's size before anything is built
  long plate_spheres = 0;
  try {
    p.validate(g.path());
    plate_spheres = roughPlateSpheres(p, powderDiameters(p), g.path());
  } catch (const InputError& e) {
    const std::string message = e.what();
    throw InputError(path_ + ": " + (message.rfind(g.path(), 0) == 0 ? "" : g.path() + ": ") +
                     message);
  }
  if (plate_spheres > 0) planBodies(g["plate"], plate_spheres);
  const SceneSpec bed = addGenerated(g, [&] { return powderBed(p); });
  out_.spec.detection.path = bed.detection.path;
  out_.spec.detection.periodic = bed.detection.periodic;
  powder_layer_ = defaultLayerWindow(p);
}

void SceneParser::planBodies(const YamlField& field, long count) {
  planned_bodies_ += static_cast<double>(count);
  if (planned_bodies_ > static_cast<double>(kMaxGeneratorCount))
    field.fail("brings the scene to " + std::to_string(static_cast<long>(planned_bodies_)) +
               " generated bodies, more than " + countLimit());
  requireMemory(planned_bodies_ * kBytesPerBody,
                path_ + ": " + field.path() + " = " + std::to_string(count) + " (" +
                    std::to_string(static_cast<long>(planned_bodies_)) +
                    " bodies in the scene so far)");
}

std::string SceneParser::countLimit() const {
  return max_count_ == 10000000 ? "10^7" : std::to_string(max_count_);
}

}  // namespace sweep
