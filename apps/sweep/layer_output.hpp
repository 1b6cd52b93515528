#pragma once
// The layer a powder-bed run leaves: metrics in layer.json and a top view of the surface
// height as a PNG (docs/powder_bed.md).
#include <string>

#include "models/granular.hpp"
#include "models/powder_bed.hpp"

namespace sweep {

// Metrics of every sphere on a free body at configuration q; spheres fixed to the world (a
// rough plate) give fixed_fraction.
LayerMetrics measureLayer(const Scene& scene, const VectorX& q, const LayerWindow& window,
                          const VectorX* v = nullptr);

// layer.json: the window and the metrics; written atomically.
void writeLayerJson(const LayerMetrics& metrics, const LayerWindow& window,
                    const std::string& path);

// The height map as an 8-bit RGB PNG, one pixel per column, x to the right and z down, the
// colour scale from the plate (dark) to 1.5 gaps (bright); written atomically.
void writeHeightMapPng(const LayerMetrics& metrics, const LayerWindow& window,
                       const std::string& path);

}  // namespace sweep
