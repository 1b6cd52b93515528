#pragma once
// Uniform-grid (cell list) broadphase for particles: spheres or disks of similar size. Cells
// are hashed, so the grid needs no bounds and costs O(N) per step whatever the spread of the
// particles. Large shapes (walls, boxes, blades) query the grid with their bounding box.
#include <cstdint>
#include <utility>
#include <vector>

#include "framework/spatial.hpp"

namespace sweep {

class GridBroadphase {
 public:
  // Bins the particles; `reach` is the largest centre distance of a pair that can be a
  // candidate (largest diameter plus the margin), so that candidates sit in adjacent cells.
  void build(const std::vector<Vector3>& centers, double reach, int dimension);

  // Pairs (i < j) of particles whose centres are closer than reach_ij(i, j); appended.
  template <class Reach>
  void findPairs(const std::vector<Vector3>& centers, Reach&& reach_ij,
                 std::vector<std::pair<int, int>>& pairs) const;

  // Calls visit(i) once for every particle whose cell meets the box [lo, hi] grown by one cell.
  template <class Visit>
  void query(const Vector3& lo, const Vector3& hi, Visit&& visit) const;

 private:
  using Cell = Eigen::Matrix<std::int64_t, 3, 1>;
  Cell cellOf(const Vector3& x) const;
  std::size_t slot(const Cell& c) const;

  int dimension_ = 3;
  double inverse_cell_ = 1.0;
  std::size_t mask_ = 0;
  std::vector<Cell> particle_cell_;
  std::vector<int> bucket_start_;  // counting-sort offsets per hash slot
  std::vector<int> sorted_;        // particles ordered by slot
  std::vector<int> cursor_;
};

template <class Reach>
void GridBroadphase::findPairs(const std::vector<Vector3>& centers, Reach&& reach_ij,
                               std::vector<std::pair<int, int>>& pairs) const {
  const int n = static_cast<int>(centers.size());
  const int dz = dimension_ == 3 ? 1 : 0;
  for (int i = 0; i < n; ++i) {
    const Cell& ci = particle_cell_[i];
    for (int x = -1; x <= 1; ++x)
      for (int y = -1; y <= 1; ++y)
        for (int z = -dz; z <= dz; ++z) {
          const Cell neighbour = ci + Cell(x, y, z);
          const std::size_t s = slot(neighbour);
          for (int k = bucket_start_[s]; k < bucket_start_[s + 1]; ++k) {
            const int j = sorted_[k];
            // other cells hashed to this slot are skipped; each pair is seen once, from i < j
            if (j <= i || particle_cell_[j] != neighbour) continue;
            const double r = reach_ij(i, j);
            if ((centers[j] - centers[i]).squaredNorm() < r * r) pairs.emplace_back(i, j);
          }
        }
  }
}

template <class Visit>
void GridBroadphase::query(const Vector3& lo, const Vector3& hi, Visit&& visit) const {
  const Cell c0 = cellOf(lo) - Cell::Ones();
  const Cell c1 = cellOf(hi) + Cell::Ones();
  const int n = static_cast<int>(particle_cell_.size());
  double cells = 1.0;
  for (int k = 0; k < dimension_; ++k) cells *= static_cast<double>(c1[k] - c0[k] + 1);
  if (cells > n) {
    // a box larger than the population: test every particle against it instead
    for (int i = 0; i < n; ++i) {
      const Cell& c = particle_cell_[i];
      bool inside = true;
      for (int k = 0; k < dimension_; ++k) inside = inside && c[k] >= c0[k] && c[k] <= c1[k];
      if (inside) visit(i);
    }
    return;
  }
  const std::int64_t z0 = dimension_ == 3 ? c0.z() : 0, z1 = dimension_ == 3 ? c1.z() : 0;
  for (std::int64_t x = c0.x(); x <= c1.x(); ++x)
    for (std::int64_t y = c0.y(); y <= c1.y(); ++y)
      for (std::int64_t z = z0; z <= z1; ++z) {
        const Cell cell(x, y, z);
        const std::size_t s = slot(cell);
        for (int k = bucket_start_[s]; k < bucket_start_[s + 1]; ++k)
          if (particle_cell_[sorted_[k]] == cell) visit(sorted_[k]);
      }
}

}  // namespace sweep
