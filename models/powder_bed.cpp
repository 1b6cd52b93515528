#include "models/powder_bed.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <sstream>

#include "framework/error.hpp"

namespace sweep {

namespace {

void require(bool ok, const std::string& owner, const std::string& field, double value,
             const std::string& rule) {
  if (ok) return;
  std::ostringstream s;
  s << owner << "." << field << ": " << rule << ", got " << value;
  throw InputError(s.str());
}

bool positive(double x) {
  return std::isfinite(x) && x > 0.0;
}

// uniform in (0, 1) from the raw generator: the same numbers with every standard library
double unit(std::mt19937& rng) {
  return (static_cast<double>(rng()) + 0.5) / 4294967296.0;
}

Pose at(const Vector3& x) {
  Pose p;
  p.translation = x;
  return p;
}

// a half-space whose outward normal is n (the shape's normal is its local z)
BodySpec plane(const std::string& name, const Vector3& point, const Vector3& n) {
  BodySpec b;
  b.name = name;
  b.kind = BodySpec::Kind::Fixed;
  b.material = "wall";
  b.shape = Shape::halfSpace();
  b.pose.translation = point;
  b.pose.rotation = Eigen::Quaterniond::FromTwoVectors(Vector3::UnitZ(), n).toRotationMatrix();
  return b;
}

BodySpec box(const std::string& name, const Vector3& center, const Vector3& size) {
  BodySpec b;
  b.name = name;
  b.kind = BodySpec::Kind::Driven;
  b.material = "wall";
  b.shape = Shape::box(size);
  b.pose = at(center);
  b.motion.kind = MotionSpec::Kind::Fixed;
  return b;
}

}  // namespace

void PowderBedParameters::validate(const std::string& o) const {
  require(count >= 1, o, "count", count, "must be >= 1");
  require(copies_across >= 1 && copies_across <= 1000, o, "copies_across", copies_across,
          "must be in [1, 1000]");
  if (sizes == Sizes::Discrete) {
    require(!diameters.empty() && diameters.size() == mass_fractions.size(), o, "mass_fractions",
            static_cast<double>(mass_fractions.size()), "must hold one fraction per diameter");
    double total = 0.0;
    for (std::size_t i = 0; i < diameters.size(); ++i) {
      require(positive(diameters[i]), o, "diameters", diameters[i], "must be > 0");
      require(std::isfinite(mass_fractions[i]) && mass_fractions[i] >= 0.0, o, "mass_fractions",
              mass_fractions[i], "must be >= 0");
      total += mass_fractions[i];
    }
    require(total > 0.0, o, "mass_fractions", total, "must not all be zero");
  } else {
    require(positive(d50), o, "d50", d50, "must be > 0");
    require(std::isfinite(geometric_std) && geometric_std >= 1.0, o, "geometric_std", geometric_std,
            "must be >= 1");
    require(positive(d_min), o, "d_min", d_min, "must be > 0");
    require(std::isfinite(d_max) && d_max > d_min, o, "d_max", d_max, "must be > d_min");
    // diameters are drawn and redrawn until they fall in [d_min, d_max]: a window in the far
    // tail would take forever. It must hold at least 1e-3 of the distribution.
    const double sigma = std::log(geometric_std);
    auto below = [&](double d) {
      const double z = std::log(d / d50);
      if (sigma == 0.0) return z >= 0.0 ? 1.0 : 0.0;
      return 0.5 * std::erfc(-z / (sigma * std::sqrt(2.0)));
    };
    const double share = below(d_max) - below(d_min);
    require(share >= 1e-3, o, "d_min", d_min,
            "with d_max = " + formatValue(d_max) + " holds a fraction " + formatValue(share) +
                " of the distribution of d50 = " + formatValue(d50) + ", geometric_std = " +
                formatValue(geometric_std) + "; it must hold at least 0.001");
  }
  require(positive(density), o, "density", density, "must be > 0");
  require(std::isfinite(friction) && friction >= 0.0, o, "friction", friction, "must be >= 0");
  require(restitution >= 0.0 && restitution <= 1.0, o, "restitution", restitution,
          "must be in [0, 1]");
  require(std::isfinite(rolling_resistance) && rolling_resistance >= 0.0, o, "rolling_resistance",
          rolling_resistance, "must be >= 0");
  require(std::isfinite(surface_energy) && surface_energy >= 0.0, o, "surface_energy",
          surface_energy, "must be >= 0");
  require(std::isfinite(adhesion_range) && adhesion_range >= 0.0, o, "adhesion_range",
          adhesion_range, "must be >= 0");
  require(std::isfinite(gravity), o, "gravity", gravity, "must be finite");
  for (const auto& [name, value] : {std::pair<const char*, double>{"length", length},
                                    {"width", width},
                                    {"height", height},
                                    {"gap", gap},
                                    {"blade_thickness", blade_thickness},
                                    {"speed", speed},
                                    {"travel", travel},
                                    {"heap_length", heap_length},
                                    {"roller_radius", roller_radius}})
    require(positive(value), o, name, value, "must be > 0");
  require(std::isfinite(blade_start) && blade_start >= 0.0, o, "blade_start", blade_start,
          "must be >= 0");
  require(std::isfinite(settle_time) && settle_time >= 0.0, o, "settle_time", settle_time,
          "must be >= 0");
  require(std::isfinite(roller_spin), o, "roller_spin", roller_spin, "must be finite");
  require(lattice_spacing >= 1.0 && lattice_spacing < 10.0, o, "lattice_spacing", lattice_spacing,
          "must be in [1, 10)");
  require(gap < height, o, "gap", gap, "must be below height");
  const double front = blade_start + (roller ? 2.0 * roller_radius : blade_thickness);
  require(front + heap_length + travel < length, o, "travel", travel,
          "must leave the heap and the blade inside the domain (blade_start + thickness + "
          "heap_length + travel < length)");
}

std::vector<double> powderDiameters(const PowderBedParameters& p) {
  std::mt19937 rng(p.seed);
  std::vector<double> d(p.count);
  if (p.sizes == PowderBedParameters::Sizes::Discrete) {
    // mass fractions to number fractions: n_i proportional to f_i / d_i^3
    std::vector<double> cumulative(p.diameters.size());
    double total = 0.0;
    for (std::size_t i = 0; i < p.diameters.size(); ++i) {
      total += p.mass_fractions[i] / std::pow(p.diameters[i], 3);
      cumulative[i] = total;
    }
    for (double& x : d) {
      const double u = unit(rng) * total;
      const std::size_t i = std::min<std::size_t>(
          std::lower_bound(cumulative.begin(), cumulative.end(), u) - cumulative.begin(),
          p.diameters.size() - 1);
      x = p.diameters[i];
    }
  } else {
    // Box-Muller on the raw generator, redrawn outside the cut
    const double sigma = std::log(p.geometric_std);
    for (double& x : d) {
      do {
        // draws in sequence: the order of a call's operands is the compiler's choice
        const double radial = unit(rng), angle = unit(rng);
        const double z = std::sqrt(-2.0 * std::log(radial)) * std::cos(2.0 * M_PI * angle);
        x = p.d50 * std::exp(sigma * z);
      } while (x < p.d_min || x > p.d_max);
    }
  }
  return d;
}

long roughPlateSpheres(const PowderBedParameters& p, const std::vector<double>& diameters,
                       const std::string& owner) {
  const double largest = *std::max_element(diameters.begin(), diameters.end());
  const double pitch = largest * p.lattice_spacing;
  require(p.heap_length / pitch < 1e6 && p.width / pitch < 1e6, owner, "heap_length", p.heap_length,
          "and width must hold fewer than 10^6 grains across");
  require(p.heap_length >= pitch && p.width >= pitch, owner, "heap_length", p.heap_length,
          "must hold one lattice pitch (and width too)");
  if (!p.rough_plate) return 0;
  const double d = std::accumulate(diameters.begin(), diameters.end(), 0.0) / diameters.size();
  const double rows = std::floor(p.length / d) + 1.0;
  const double across = std::max(1.0, std::floor(p.width / d)) * p.copies_across + 2.0;
  require(rows * across < 1e6, owner, "length", p.length,
          "gives a rough plate of more than 10^6 spheres (" + formatValue(rows) + " x " +
              formatValue(across) + " of the mean diameter " + formatValue(d) + ")");
  return static_cast<long>(rows * across);
}

SceneSpec powderBed(const PowderBedParameters& p) {
  p.validate();
  const std::vector<double> diameters = powderDiameters(p);
  roughPlateSpheres(p, diameters);  // the lattice and plate checks, before anything is built
  const double largest = *std::max_element(diameters.begin(), diameters.end());
  SceneSpec spec;
  spec.source = "powder_bed";
  spec.dimension = 3;
  spec.gravity = Vector3(0.0, -p.gravity, 0.0);
  spec.materials = {{"powder", p.density}, {"wall", 0.0}};
  ContactLaw law{p.friction, p.restitution, p.rolling_resistance};
  law.surface_energy = p.surface_energy;
  law.adhesion_range = p.adhesion_range;
  spec.laws = {{"powder", "powder", law}, {"powder", "wall", law}};
  spec.detection.path = DetectionPathChoice::Analytic;
  spec.detection.periodic.axis = 2;
  spec.detection.periodic.low = 0.0;
  spec.detection.periodic.high = p.period();

  spec.bodies.push_back(plane("plate", Vector3::Zero(), Vector3::UnitY()));
  spec.bodies.push_back(plane("wall_start", Vector3::Zero(), Vector3::UnitX()));
  spec.bodies.push_back(plane("wall_end", Vector3(p.length, 0.0, 0.0), -Vector3::UnitX()));
  // blade and temporary walls span the period and a grain beyond each side, so that every
  // image of a grain meets them
  const double span = p.period() + 4.0 * largest;
  const double z_mid = 0.5 * p.period();
  const double spread_time = p.travel / p.speed;
  double front = 0.0;  // x of the face the heap rests against
  if (!p.roller) {
    BodySpec blade = box(
        "blade", Vector3(p.blade_start + 0.5 * p.blade_thickness, 0.5 * (p.gap + p.height), z_mid),
        Vector3(p.blade_thickness, p.height - p.gap, span));
    blade.motion.kind = MotionSpec::Kind::Keyframes;
    blade.motion.times = {p.settle_time, p.settle_time + spread_time};
    blade.motion.positions = {blade.pose.translation,
                              blade.pose.translation + Vector3(p.travel, 0.0, 0.0)};
    spec.bodies.push_back(blade);
    front = p.blade_start + p.blade_thickness;
  } else {
    // a capsule along z: translation from settle_time on, spin against the rolling direction
    BodySpec roller;
    roller.name = "roller";
    roller.kind = BodySpec::Kind::Driven;
    roller.material = "wall";
    roller.shape = Shape::capsule(p.roller_radius, span);
    roller.pose = at(Vector3(p.blade_start + p.roller_radius, p.gap + p.roller_radius, z_mid));
    // a driven velocity motion cannot wait: the roller is held by the gate until then, and
    // moves from t = 0 when settle_time is 0
    roller.motion.kind = MotionSpec::Kind::Velocity;
    roller.motion.linear_velocity = Vector3(p.speed, 0.0, 0.0);
    const double spin = p.roller_spin != 0.0 ? p.roller_spin : p.speed / p.roller_radius;
    roller.motion.angular_velocity = Vector3(0.0, 0.0, spin);
    roller.pose.translation.x() -= p.speed * p.settle_time;  // at blade_start when spreading
    spec.bodies.push_back(roller);
    front = p.blade_start + 2.0 * p.roller_radius;
  }
  if (p.settle_time > 0.0) {
    // the gate closes the gap under the blade, the fence the heap's front, until settle_time
    BodySpec gate = box("gate", Vector3(front - 0.5 * p.blade_thickness, 0.5 * p.height, z_mid),
                        Vector3(p.blade_thickness, p.height, span));
    gate.motion.removal_time = p.settle_time;
    spec.bodies.push_back(gate);
    BodySpec fence = box(
        "fence", Vector3(front + p.heap_length + 0.5 * p.blade_thickness, 0.5 * p.height, z_mid),
        Vector3(p.blade_thickness, p.height, span));
    fence.motion.removal_time = p.settle_time;
    spec.bodies.push_back(fence);
  }

  if (p.rough_plate) {
    // frozen spheres of the mean number diameter, centres on the plate, one row past each
    // periodic boundary so that grains at the boundary meet them too
    const double d = std::accumulate(diameters.begin(), diameters.end(), 0.0) / diameters.size();
    // the z pitch is fitted to one copy's width, so that the copies' plates match
    const int across = std::max(1, static_cast<int>(std::floor(p.width / d)));
    const double pitch_z = p.width / across;
    long k = 0;
    for (double x = 0.5 * d; x < p.length; x += d)
      for (long iz = -1; iz <= static_cast<long>(across) * p.copies_across; ++iz) {
        BodySpec b;
        b.name = "plate_sphere" + std::to_string(k++);
        b.kind = BodySpec::Kind::Fixed;
        b.material = "wall";
        b.shape = Shape::sphere(0.5 * d);
        b.pose = at(Vector3(x, 0.0, (iz + 0.5) * pitch_z));
        spec.bodies.push_back(b);
      }
  }

  // the heap: a lattice with pitch >= the largest diameter, the z pitch fitted to the period,
  // jittered by a fraction of the free space so that columns do not stack exactly
  const double pitch = largest * p.lattice_spacing;
  const long nx = static_cast<long>(std::floor(p.heap_length / pitch));
  const long nz = static_cast<long>(std::floor(p.width / pitch));
  const double pitch_z = p.width / nz;
  const double base = p.rough_plate ? largest : 0.0;
  const double jitter = 0.5 * (pitch - largest);
  for (int copy = 0; copy < p.copies_across; ++copy) {
    std::mt19937 rng(p.seed + 1);  // the same jitter in every copy
    const double offset_z = copy * p.width;
    for (int i = 0; i < p.count; ++i) {
      const long ix = i % nx, iz = (i / nx) % nz, iy = i / (nx * nz);
      BodySpec b;
      b.name = "p" + std::to_string(static_cast<long>(copy) * p.count + i);
      b.shape = Shape::sphere(0.5 * diameters[i]);
      b.material = "powder";
      // z drawn first, x second: the order GCC gave the constructor's arguments, sequenced
      const double shake_z = jitter * (2.0 * unit(rng) - 1.0);
      const Vector3 shake(jitter * (2.0 * unit(rng) - 1.0), 0.0, shake_z);
      b.pose = at(Vector3(front + (ix + 0.5) * pitch, base + (iy + 0.5) * pitch,
                          offset_z + (iz + 0.5) * pitch_z) +
                  shake);
      spec.bodies.push_back(b);
    }
  }
  return spec;
}

namespace {
// cells of about `size` across `span`, whole and at least one (as a double: no overflow)
double gridCount(double span, double size) {
  return std::max(1.0, std::round(span / size));
}
}  // namespace

void LayerWindow::validate(const std::string& owner) const {
  require(std::isfinite(x_min) && std::isfinite(x_max) && x_max > x_min, owner, "x_max", x_max,
          "must be > x_min");
  require(std::isfinite(z_min) && std::isfinite(z_max) && z_max > z_min, owner, "z_max", z_max,
          "must be > z_min");
  require(std::isfinite(plate), owner, "plate", plate, "must be finite");
  require(positive(gap), owner, "gap", gap, "must be > 0");
  require(positive(cell), owner, "cell", cell, "must be > 0");
  require(positive(resolution), owner, "resolution", resolution, "must be > 0");
  // counted per axis as layerMetrics does (at least one each): a product alone lets one axis
  // of 10^12 columns through beside one of 10^-6; the height map's image takes 10^6 a side
  const double columns_x = gridCount(x_max - x_min, resolution);
  const double columns_z = gridCount(z_max - z_min, resolution);
  require(columns_x <= 1e6 && columns_z <= 1e6, owner, "resolution", resolution,
          "gives more than 10^6 height-map columns along x or z");
  require(columns_x * columns_z <= 1e7, owner, "resolution", resolution,
          "gives more than 10^7 height-map columns");
  const double cells = gridCount(x_max - x_min, cell) * gridCount(z_max - z_min, cell);
  require(cells <= 1e7, owner, "cell", cell, "gives more than 10^7 packing cells");
}

LayerWindow defaultLayerWindow(const PowderBedParameters& p) {
  LayerWindow w;
  w.z_min = 0.0;
  w.z_max = p.period();
  w.gap = p.gap;
  w.plate = 0.0;
  return w;
}

LayerMetrics layerMetrics(const std::vector<Vector3>& centers, const std::vector<double>& radii,
                          const LayerWindow& w) {
  LayerMetrics m;
  const double res = w.resolution;
  m.columns_x = static_cast<int>(gridCount(w.x_max - w.x_min, res));
  m.columns_z = static_cast<int>(gridCount(w.z_max - w.z_min, res));
  const double dx = (w.x_max - w.x_min) / m.columns_x, dz = (w.z_max - w.z_min) / m.columns_z;
  m.height_map.assign(static_cast<std::size_t>(m.columns_x) * m.columns_z, 0.0f);
  std::vector<double> in_gap(m.height_map.size(), 0.0), solid(m.height_map.size(), 0.0);
  for (std::size_t s = 0; s < centers.size(); ++s) {
    const Vector3& c = centers[s];
    const double r = radii[s];
    if (c.x() + r < w.x_min || c.x() - r > w.x_max) continue;
    ++m.particles;
    if (m.highest_particle < 0 || c.y() + r - w.plate > m.highest_top) {
      m.highest_top = c.y() + r - w.plate;
      m.highest_particle = static_cast<int>(s);
    }
    const int i0 = std::max(0, static_cast<int>(std::floor((c.x() - r - w.x_min) / dx)));
    const int i1 =
        std::min(m.columns_x - 1, static_cast<int>(std::floor((c.x() + r - w.x_min) / dx)));
    const int k0 = static_cast<int>(std::floor((c.z() - r - w.z_min) / dz));
    const int k1 = static_cast<int>(std::floor((c.z() + r - w.z_min) / dz));
    for (int k = k0; k <= k1; ++k) {
      const double z = w.z_min + (k + 0.5) * dz;
      const int row = ((k % m.columns_z) + m.columns_z) % m.columns_z;  // periodic in z
      for (int i = i0; i <= i1; ++i) {
        const double x = w.x_min + (i + 0.5) * dx;
        const double h2 = r * r - (x - c.x()) * (x - c.x()) - (z - c.z()) * (z - c.z());
        if (h2 <= 0.0) continue;
        const double h = std::sqrt(h2);
        const double bottom = c.y() - h - w.plate, top = c.y() + h - w.plate;
        const std::size_t cell = static_cast<std::size_t>(row) * m.columns_x + i;
        solid[cell] += top - std::max(bottom, 0.0) > 0.0 ? top - std::max(bottom, 0.0) : 0.0;
        in_gap[cell] += std::max(0.0, std::min(top, w.gap) - std::max(bottom, 0.0));
        m.height_map[cell] = std::max(m.height_map[cell], static_cast<float>(top));
      }
    }
  }
  const double n = static_cast<double>(m.height_map.size());
  double gap_sum = 0.0, solid_sum = 0.0, height_sum = 0.0, height2 = 0.0;
  int covered = 0;
  for (std::size_t k = 0; k < m.height_map.size(); ++k) {
    gap_sum += in_gap[k];
    solid_sum += solid[k];
    const double h = std::max(0.0f, m.height_map[k]);
    height_sum += h;
    height2 += h * h;
    covered += solid[k] > 0.0 ? 1 : 0;
  }
  m.packing_fraction = gap_sum / (n * w.gap);
  m.solid_thickness = solid_sum / n;
  m.height_mean = m.effective_depth = height_sum / n;
  m.height_std = std::sqrt(std::max(0.0, height2 / n - m.height_mean * m.height_mean));
  m.coverage = covered / n;

  // packing per cell of about `cell` size, whole columns each
  const int cx = static_cast<int>(gridCount(w.x_max - w.x_min, w.cell));
  const int cz = static_cast<int>(gridCount(w.z_max - w.z_min, w.cell));
  std::vector<double> cell_gap(static_cast<std::size_t>(cx) * cz, 0.0);
  std::vector<int> cell_columns(cell_gap.size(), 0);
  for (int row = 0; row < m.columns_z; ++row)
    for (int i = 0; i < m.columns_x; ++i) {
      const int a = std::min(cx - 1, i * cx / m.columns_x);
      const int b = std::min(cz - 1, row * cz / m.columns_z);
      cell_gap[static_cast<std::size_t>(b) * cx + a] +=
          in_gap[static_cast<std::size_t>(row) * m.columns_x + i];
      ++cell_columns[static_cast<std::size_t>(b) * cx + a];
    }
  m.cells = cx * cz;
  m.cell_min = std::numeric_limits<double>::infinity();
  m.cell_max = -std::numeric_limits<double>::infinity();
  double sum = 0.0, sum2 = 0.0;
  for (std::size_t k = 0; k < cell_gap.size(); ++k) {
    const double phi = cell_gap[k] / (cell_columns[k] * w.gap);
    sum += phi;
    sum2 += phi * phi;
    m.cell_min = std::min(m.cell_min, phi);
    m.cell_max = std::max(m.cell_max, phi);
  }
  m.cell_mean = sum / m.cells;
  m.cell_std = std::sqrt(std::max(0.0, sum2 / m.cells - m.cell_mean * m.cell_mean));
  return m;
}

}  // namespace sweep
