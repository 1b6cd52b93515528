#pragma once
// Uniform-grid (cell list) broadphase for particles: spheres or disks of similar size.
// Particles are counting-sorted by cell. When the particles' bounding box holds a moderate
// number of cells the grid is dense: the cells of a row are contiguous in the sorted order,
// so a neighbourhood is a few contiguous runs and each pair is visited once (half stencil).
// Otherwise (a grain escaped far away) cells are hashed, so memory stays O(N).
#include <cstdint>
#include <utility>
#include <vector>

#include "framework/spatial.hpp"

namespace sweep {

class GridBroadphase {
 public:
  // Bins the particles; `reach` is the largest centre distance of a candidate pair (largest
  // diameter plus the margin), so that candidates sit in adjacent cells.
  void build(const std::vector<Vector3>& centers, const std::vector<double>& radii, double reach,
             int dimension);

  // Pairs (i < j) of particles with |c_i - c_j| < r_i + r_j + margin; appended. On up to
  // `threads` threads, each scanning a run of the binned particles into its own list of
  // `runs`, the lists joined in order: the same pairs in the same order for every count.
  void findPairs(double margin, std::vector<std::pair<int, int>>& pairs, int threads = 1,
                 std::vector<std::vector<std::pair<int, int>>>* runs = nullptr) const;

  // Calls visit(i) once for every particle whose cell meets the box [lo, hi] grown by one
  // cell.
  template <class Visit>
  void query(const Vector3& lo, const Vector3& hi, Visit&& visit) const;

  bool dense() const { return dense_; }

 private:
  using Cell = Eigen::Matrix<std::int64_t, 3, 1>;
  Cell cellOf(const Vector3& x) const;
  std::size_t hashSlot(const Cell& c) const;
  std::size_t denseSlot(const Cell& c) const {
    return static_cast<std::size_t>(c.x() + extent_.x() * (c.y() + extent_.y() * c.z()));
  }
  // the pairs found from the binned particles [begin, end)
  void findPairsDense(double margin, int first, int last,
                      std::vector<std::pair<int, int>>& pairs) const;
  void findPairsHashed(double margin, int begin, int end,
                       std::vector<std::pair<int, int>>& pairs) const;

  int dimension_ = 3;
  bool dense_ = true;
  double inverse_cell_ = 1.0;
  Vector3 origin_ = Vector3::Zero();
  Cell extent_ = Cell::Ones();  // dense grid size in cells
  std::size_t mask_ = 0;        // hashed grid: table size - 1
  std::vector<Cell> particle_cell_;
  std::vector<std::size_t> particle_slot_;
  std::vector<int> slot_start_;  // counting-sort offsets per slot
  std::vector<int> cursor_;
  std::vector<int> sorted_;             // particle ids ordered by slot
  std::vector<Vector3> sorted_center_;  // centres and radii in that order: contiguous scans
  std::vector<double> sorted_radius_;
};

template <class Visit>
void GridBroadphase::query(const Vector3& lo, const Vector3& hi, Visit&& visit) const {
  Cell c0 = cellOf(lo) - Cell::Ones();
  Cell c1 = cellOf(hi) + Cell::Ones();
  if (dimension_ == 2) c0.z() = c1.z() = 0;
  const int n = static_cast<int>(sorted_.size());
  if (dense_) {
    for (int k = 0; k < 3; ++k) {
      c0[k] = std::max<std::int64_t>(c0[k], 0);
      c1[k] = std::min<std::int64_t>(c1[k], extent_[k] - 1);
      if (c1[k] < c0[k]) return;
    }
    for (std::int64_t z = c0.z(); z <= c1.z(); ++z)
      for (std::int64_t y = c0.y(); y <= c1.y(); ++y) {
        const int begin = slot_start_[denseSlot(Cell(c0.x(), y, z))];
        const int end = slot_start_[denseSlot(Cell(c1.x(), y, z)) + 1];
        for (int k = begin; k < end; ++k) visit(sorted_[k]);
      }
    return;
  }
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
  for (std::int64_t z = c0.z(); z <= c1.z(); ++z)
    for (std::int64_t y = c0.y(); y <= c1.y(); ++y)
      for (std::int64_t x = c0.x(); x <= c1.x(); ++x) {
        const Cell cell(x, y, z);
        const std::size_t s = hashSlot(cell);
        for (int k = slot_start_[s]; k < slot_start_[s + 1]; ++k)
          if (particle_cell_[sorted_[k]] == cell) visit(sorted_[k]);
      }
}

}  // namespace sweep
