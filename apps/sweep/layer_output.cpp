#include "apps/sweep/layer_output.hpp"

#include <nlohmann/json.hpp>

#include <png.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "apps/sweep/run.hpp"
#include "framework/kinematics.hpp"

namespace sweep {

LayerMetrics measureLayer(const Scene& scene, const VectorX& q, const LayerWindow& window,
                          const VectorX* v) {
  Data data(scene.model);
  if (v)
    forwardKinematics(scene.model, data, q, *v);
  else
    forwardKinematics(scene.model, data, q);
  std::vector<Vector3> centers, fixed_centers;
  std::vector<double> radii, fixed_radii, speeds;
  for (const Geometry& g : scene.cmodel.geometries) {
    if (g.shape.type != ShapeType::Sphere) continue;
    if (g.body.kind == BodyRef::Kind::Dynamic) {
      centers.push_back((data.world_pose[g.body.index] * g.placement).translation);
      radii.push_back(g.shape.radius);
      if (v) {
        // spatial velocity in body coordinates: (angular, velocity of the body origin)
        const Vector6& twist = data.velocity[g.body.index];
        const Vector3 at_centre = twist.tail<3>() + twist.head<3>().cross(g.placement.translation);
        speeds.push_back(at_centre.norm());
      }
    } else if (g.body.kind == BodyRef::Kind::World) {
      // the window's columns wrap in z like the periodic cell; a rough plate also holds
      // copies of its edge rows just outside the cell, which that wrap would count twice
      const Vector3& c = g.placement.translation;
      if (c.z() < window.z_min || c.z() >= window.z_max) continue;
      fixed_centers.push_back(c);
      fixed_radii.push_back(g.shape.radius);
    }
  }
  LayerMetrics metrics = layerMetrics(centers, radii, window);
  if (v && metrics.highest_particle >= 0)
    metrics.highest_top_speed = speeds[metrics.highest_particle];
  if (!fixed_centers.empty())
    metrics.fixed_fraction = layerMetrics(fixed_centers, fixed_radii, window).packing_fraction;
  // a gap filled by the fixed spheres leaves no free volume to pack
  metrics.free_volume_packing_fraction =
      metrics.fixed_fraction < 1.0 ? metrics.packing_fraction / (1.0 - metrics.fixed_fraction)
                                   : 0.0;
  return metrics;
}

void writeLayerJson(const LayerMetrics& m, const LayerWindow& w, const std::string& path) {
  nlohmann::ordered_json j;
  j["window"] = {{"x_min", w.x_min}, {"x_max", w.x_max},          {"z_min", w.z_min},
                 {"z_max", w.z_max}, {"plate", w.plate},          {"gap", w.gap},
                 {"cell", w.cell},   {"resolution", w.resolution}};
  j["packing_fraction"] = m.packing_fraction;
  j["fixed_fraction"] = m.fixed_fraction;
  j["free_volume_packing_fraction"] = m.free_volume_packing_fraction;
  j["effective_depth"] = m.effective_depth;
  j["effective_depth_over_gap"] = m.effective_depth / w.gap;
  j["solid_thickness"] = m.solid_thickness;
  j["coverage"] = m.coverage;
  j["height"] = {{"mean", m.height_mean},
                 {"std", m.height_std},
                 {"highest_top", m.highest_top},
                 {"highest_top_speed", m.highest_top_speed}};
  j["cell_packing"] = {{"cells", m.cells},
                       {"mean", m.cell_mean},
                       {"std", m.cell_std},
                       {"min", m.cell_min},
                       {"max", m.cell_max}};
  j["particles"] = m.particles;
  writeFileAtomically(path, jsonText(j));
}

namespace {

// a perceptually ordered dark-blue to yellow ramp (viridis at five stops, linear between)
std::array<unsigned char, 3> colour(double t) {
  static const double stops[5][3] = {
      {68, 1, 84}, {59, 82, 139}, {33, 145, 140}, {94, 201, 98}, {253, 231, 37}};
  t = std::clamp(t, 0.0, 1.0) * 4.0;
  const int i = std::min(3, static_cast<int>(t));
  const double f = t - i;
  std::array<unsigned char, 3> rgb;
  for (int c = 0; c < 3; ++c)
    rgb[c] =
        static_cast<unsigned char>(std::lround(stops[i][c] + f * (stops[i + 1][c] - stops[i][c])));
  return rgb;
}

}  // namespace

void writeHeightMapPng(const LayerMetrics& m, const LayerWindow& w, const std::string& path) {
  const int width = m.columns_x, height = m.columns_z;
  std::vector<unsigned char> pixels;
  pixels.reserve(static_cast<std::size_t>(height) * width * 3);
  const double top = 1.5 * w.gap;
  for (int row = 0; row < height; ++row) {
    for (int i = 0; i < width; ++i) {
      const float h = m.height_map[static_cast<std::size_t>(row) * width + i];
      const auto rgb = h > 0.0f ? colour(h / top) : std::array<unsigned char, 3>{0, 0, 0};
      pixels.insert(pixels.end(), rgb.begin(), rgb.end());
    }
  }
  // libpng's simplified API, into memory, so that the file is written whole or not at all
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = static_cast<png_uint_32>(width);
  image.height = static_cast<png_uint_32>(height);
  image.format = PNG_FORMAT_RGB;
  png_alloc_size_t size = 0;
  if (!png_image_write_to_memory(&image, nullptr, &size, 0, pixels.data(), 0, nullptr))
    throw std::runtime_error(path + ": cannot encode the height map: " + image.message);
  std::string png(size, '\0');
  if (!png_image_write_to_memory(&image, png.data(), &size, 0, pixels.data(), 0, nullptr))
    throw std::runtime_error(path + ": cannot encode the height map: " + image.message);
  png.resize(size);
  writeFileAtomically(path, png);
}

}  // namespace sweep
