#include "contact/grid_broadphase.hpp"

#include <cmath>

namespace sweep {

GridBroadphase::Cell GridBroadphase::cellOf(const Vector3& x) const {
  Cell c;
  for (int k = 0; k < 3; ++k)
    c[k] = k < dimension_ ? static_cast<std::int64_t>(std::floor(x[k] * inverse_cell_)) : 0;
  return c;
}

std::size_t GridBroadphase::slot(const Cell& c) const {
  // the spatial hash of Teschner et al. (2003)
  const std::uint64_t h = static_cast<std::uint64_t>(c.x()) * 73856093ULL ^
                          static_cast<std::uint64_t>(c.y()) * 19349663ULL ^
                          static_cast<std::uint64_t>(c.z()) * 83492791ULL;
  return static_cast<std::size_t>(h) & mask_;
}

void GridBroadphase::build(const std::vector<Vector3>& centers, double reach, int dimension) {
  dimension_ = dimension;
  inverse_cell_ = reach > 0.0 ? 1.0 / reach : 1.0;
  const std::size_t n = centers.size();
  std::size_t table = 16;
  while (table < 2 * n) table *= 2;
  mask_ = table - 1;

  particle_cell_.resize(n);
  bucket_start_.assign(table + 1, 0);
  sorted_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    particle_cell_[i] = cellOf(centers[i]);
    ++bucket_start_[slot(particle_cell_[i]) + 1];
  }
  for (std::size_t s = 0; s < table; ++s) bucket_start_[s + 1] += bucket_start_[s];
  // stable fill keeps particles in index order within a slot: deterministic pair order
  cursor_.assign(bucket_start_.begin(), bucket_start_.end() - 1);
  for (std::size_t i = 0; i < n; ++i)
    sorted_[cursor_[slot(particle_cell_[i])]++] = static_cast<int>(i);
}

}  // namespace sweep
