#pragma once
// Powder-bed spreading for laser powder-bed fusion (docs/powder_bed.md): metal spheres dosed
// as a heap in front of a blade (or a counter-rotating roller), held by temporary walls while
// they settle, then spread over a build plate in one pass. y is up, x the spreading direction,
// z across the width, periodic. One builder, reused by the `powder_bed` scene generator, the
// tests and the benchmarks; the layer metrics judge the result.
#include <cstdint>
#include <string>
#include <vector>

#include "models/scene_spec.hpp"

namespace sweep {

struct PowderBedParameters {
  int count = 3500;
  // particle sizes: diameters drawn by mass fractions (Discrete), or a log-normal number
  // distribution of median d50 and geometric standard deviation, cut to [d_min, d_max]
  enum class Sizes { Discrete, LogNormal };
  Sizes sizes = Sizes::Discrete;
  std::vector<double> diameters = {30e-6, 40e-6, 50e-6};  // m
  std::vector<double> mass_fractions = {0.3, 0.4, 0.3};
  double d50 = 30e-6, geometric_std = 1.3, d_min = 15e-6, d_max = 45e-6;
  double density = 4430.0;  // Ti-6Al-4V, kg/m^3
  double friction = 0.5;    // particle-particle and particle-wall
  double restitution = 0.5;
  double rolling_resistance = 0.1;
  // adhesion of every pair (ContactLaw): DMT pull-off 4 pi gamma R*, within adhesion_range
  double surface_energy = 0.0;  // J/m^2
  double adhesion_range = 0.0;  // m
  double gravity = 9.81;
  double length = 6e-3;    // domain along x
  double width = 0.4e-3;   // periodic period along z
  double height = 1.6e-3;  // top of the blade
  double gap = 100e-6;     // blade lower edge above the plate
  double blade_thickness = 0.2e-3;
  double blade_start = 0.2e-3;    // x of the blade's trailing face at t = 0
  double speed = 0.1;             // m/s
  double travel = 4.2e-3;         // m
  double heap_length = 1.2e-3;    // along x, in front of the blade
  double settle_time = 0.03;      // s: temporary walls removed, spreading starts
  double lattice_spacing = 1.05;  // heap lattice pitch / largest diameter
  bool roller = false;            // a counter-rotating roller instead of the blade
  double roller_radius = 0.25e-3;
  double roller_spin = 0.0;  // rad/s about +z; 0: counter-rotating at speed / radius
  bool rough_plate = false;  // a frozen layer of spheres (the mean number diameter) on the plate
  // The bed repeated side by side across z: the period becomes width * copies_across and every
  // copy holds the same `count` spheres (sizes, lattice and jitter), so that a state settled
  // with one copy can be tiled across (scripts/tile_state.py) instead of settling a wide heap.
  int copies_across = 1;
  std::uint32_t seed = 1;

  // InputError "<owner>.<parameter>: rule, got value"
  void validate(const std::string& owner = "powder_bed") const;
  double spreadEnd() const { return settle_time + travel / speed; }
  double period() const { return width * copies_across; }  // the periodic width along z
};

// Where and how the spread layer is judged.
struct LayerWindow {
  double x_min = 1.5e-3, x_max = 3.5e-3;  // along the spreading direction
  double z_min = 0.0, z_max = 0.4e-3;     // across (the periodic width)
  double plate = 0.0;                     // y of the plate
  double gap = 100e-6;                    // nominal layer thickness
  double cell = 200e-6;                   // size of the cells of the per-cell packing
  double resolution = 2e-6;               // column size of the height map

  void validate(const std::string& owner) const;  // InputError naming the field
};

// Sphere diameters of the powder, in heap order.
std::vector<double> powderDiameters(const PowderBedParameters& parameters);

// The frozen spheres a rough plate adds (0 for a flat plate), from the powder's diameters,
// after the checks that the heap's lattice and the plate fit (InputError naming the field):
// cheap, so that a scene can plan its memory before powderBed builds anything.
long roughPlateSpheres(const PowderBedParameters& parameters, const std::vector<double>& diameters,
                       const std::string& owner = "powder_bed");

// The scene: plate (and the frozen spheres of a rough plate), end walls, blade or roller,
// temporary walls around the heap, the spheres on a jittered lattice, the periodic width.
SceneSpec powderBed(const PowderBedParameters& parameters);
LayerWindow defaultLayerWindow(const PowderBedParameters& parameters);

struct LayerMetrics {
  double packing_fraction = 0.0;  // solid volume in [plate, plate + gap] / window volume
  double solid_thickness = 0.0;   // all solid above the window / window area
  double effective_depth = 0.0;   // mean surface height, empty columns at the plate
  double coverage = 0.0;          // fraction of plate area under at least one particle
  double height_mean = 0.0, height_std = 0.0;  // surface height over all columns
  double cell_mean = 0.0, cell_std = 0.0, cell_min = 0.0, cell_max = 0.0;  // per-cell packing
  int cells = 0;
  int particles = 0;          // spheres touching the window's columns
  double highest_top = 0.0;   // highest sphere top over the window, above the plate
  int highest_particle = -1;  // index of the sphere with that top in the centres given
  // speed of that sphere (measureLayer with velocities): a grain in flight at the end of a run
  // stands there only for the moment, and is not a grain the spreader left above the gap
  double highest_top_speed = 0.0;
  // Spheres that do not move (a rough plate) take part of the gap's volume themselves; the
  // grains' packing fraction over what they leave free compares rough and flat plates.
  double fixed_fraction = 0.0;  // fixed spheres' volume in [plate, plate + gap] / window
  double free_volume_packing_fraction = 0.0;  // packing_fraction / (1 - fixed_fraction)
  // surface height above the plate per column, row-major (z rows, x columns)
  int columns_x = 0, columns_z = 0;
  std::vector<float> height_map;
};

// Metrics of the spheres (centre, radius) over the window: each sphere adds its vertical
// chord to every column its footprint covers (exact in the limit of fine columns).
LayerMetrics layerMetrics(const std::vector<Vector3>& centers, const std::vector<double>& radii,
                          const LayerWindow& window);

}  // namespace sweep
