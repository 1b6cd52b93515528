#include "contact/grid_broadphase.hpp"

#include <algorithm>
#include <cmath>

namespace sweep {

GridBroadphase::Cell GridBroadphase::cellOf(const Vector3& x) const {
  Cell c = Cell::Zero();
  // the origin is the particles' lower corner: particles have non-negative offsets, and
  // truncation is floor for them (queries below the corner round towards it, still safe)
  // far-away points (a body placed or thrown 1e100 m off) share the outermost cells instead
  // of overflowing the cell index; the narrowphase still sees their true distances
  constexpr double far = 1e15;
  for (int k = 0; k < dimension_; ++k) {
    const double scaled = (x[k] - origin_[k]) * inverse_cell_;
    c[k] = static_cast<std::int64_t>(std::isnan(scaled) ? 0.0 : std::clamp(scaled, -far, far));
  }
  return c;
}

std::size_t GridBroadphase::hashSlot(const Cell& c) const {
  // the spatial hash of Teschner et al. (2003)
  const std::uint64_t h = static_cast<std::uint64_t>(c.x()) * 73856093ULL ^
                          static_cast<std::uint64_t>(c.y()) * 19349663ULL ^
                          static_cast<std::uint64_t>(c.z()) * 83492791ULL;
  return static_cast<std::size_t>(h) & mask_;
}

void GridBroadphase::build(const std::vector<Vector3>& centers, const std::vector<double>& radii,
                           double reach, int dimension) {
  dimension_ = dimension;
  inverse_cell_ = reach > 0.0 ? 1.0 / reach : 1.0;
  const std::size_t n = centers.size();

  // dense when the bounding box holds at most a few cells per particle
  Vector3 lo = Vector3::Zero(), hi = Vector3::Zero();
  if (n > 0) {
    lo = hi = centers[0];
    for (const Vector3& c : centers) {
      lo = lo.cwiseMin(c);
      hi = hi.cwiseMax(c);
    }
  }
  origin_ = lo;
  double cells = 1.0;
  for (int k = 0; k < 3; ++k) {
    const double span = k < dimension ? std::floor((hi[k] - lo[k]) * inverse_cell_) + 1.0 : 1.0;
    extent_[k] = static_cast<std::int64_t>(std::min(span, 1e15));
    cells *= span;
  }
  dense_ = cells <= 8.0 * static_cast<double>(n) + 64.0;
  std::size_t slots = 0;
  if (dense_) {
    slots = static_cast<std::size_t>(cells);
  } else {
    slots = 16;
    while (slots < 2 * n) slots *= 2;
    mask_ = slots - 1;
  }

  particle_cell_.resize(n);
  particle_slot_.resize(n);
  slot_start_.assign(slots + 1, 0);
  for (std::size_t i = 0; i < n; ++i) {
    particle_cell_[i] = cellOf(centers[i]);
    particle_slot_[i] = dense_ ? denseSlot(particle_cell_[i]) : hashSlot(particle_cell_[i]);
    ++slot_start_[particle_slot_[i] + 1];
  }
  for (std::size_t s = 0; s < slots; ++s) slot_start_[s + 1] += slot_start_[s];
  // stable fill: particles keep index order within a slot, so the pair order is reproducible
  cursor_.assign(slot_start_.begin(), slot_start_.end() - 1);
  sorted_.resize(n);
  sorted_center_.resize(n);
  sorted_radius_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const int k = cursor_[particle_slot_[i]]++;
    sorted_[k] = static_cast<int>(i);
    sorted_center_[k] = centers[i];
    sorted_radius_[k] = radii[i];
  }
}

void GridBroadphase::findPairs(double margin, std::vector<std::pair<int, int>>& pairs, int threads,
                               std::vector<std::vector<std::pair<int, int>>>* runs) const {
  const int n = static_cast<int>(sorted_.size());
  // a particle's scan costs 50-100 ns, a parallel region about 5 us: from kParallelParticles a
  // thread the runs pay (the 3 500-sphere powder bed's detection 1.19x faster on two threads)
  constexpr int kParallelParticles = 1024;
  const int count = runs == nullptr ? 1 : std::max(1, std::min(threads, n / kParallelParticles));
  if (count == 1) {
    if (dense_)
      findPairsDense(margin, 0, n, pairs);
    else
      findPairsHashed(margin, 0, n, pairs);
    return;
  }
  if (runs->size() < static_cast<std::size_t>(count)) runs->resize(count);
#pragma omp parallel for schedule(static, 1) num_threads(count)
  for (int r = 0; r < count; ++r) {
    // the list on this thread's stack while it fills it: the runs' vector headers share cache
    // lines, which every append would bounce
    std::vector<std::pair<int, int>> out;
    out.swap((*runs)[r]);
    out.clear();
    const int begin = static_cast<int>(static_cast<long>(n) * r / count);
    const int end = static_cast<int>(static_cast<long>(n) * (r + 1) / count);
    if (dense_)
      findPairsDense(margin, begin, end, out);
    else
      findPairsHashed(margin, begin, end, out);
    out.swap((*runs)[r]);
  }
  for (int r = 0; r < count; ++r) pairs.insert(pairs.end(), (*runs)[r].begin(), (*runs)[r].end());
}

void GridBroadphase::findPairsDense(double margin, int first, int last,
                                    std::vector<std::pair<int, int>>& pairs) const {
  auto scan = [&](int k, int begin, int end) {
    const Vector3& ck = sorted_center_[k];
    const double rk = sorted_radius_[k] + margin;
    for (int m = begin; m < end; ++m) {
      const double reach = rk + sorted_radius_[m];
      if ((sorted_center_[m] - ck).squaredNorm() < reach * reach) {
        const int a = sorted_[k], b = sorted_[m];
        pairs.emplace_back(std::min(a, b), std::max(a, b));
      }
    }
  };
  const std::int64_t nx = extent_.x(), ny = extent_.y(), nz = extent_.z();
  for (int k = first; k < last; ++k) {
    const Cell& c = particle_cell_[sorted_[k]];
    const std::int64_t x0 = std::max<std::int64_t>(c.x() - 1, 0);
    const std::int64_t x1 = std::min<std::int64_t>(c.x() + 1, nx - 1);
    // half stencil: the rest of this row from k on, then the rows above and in front
    scan(k, k + 1, slot_start_[denseSlot(Cell(x1, c.y(), c.z())) + 1]);
    if (c.y() + 1 < ny)
      scan(k, slot_start_[denseSlot(Cell(x0, c.y() + 1, c.z()))],
           slot_start_[denseSlot(Cell(x1, c.y() + 1, c.z())) + 1]);
    if (c.z() + 1 < nz)
      for (std::int64_t y = std::max<std::int64_t>(c.y() - 1, 0);
           y <= std::min<std::int64_t>(c.y() + 1, ny - 1); ++y)
        scan(k, slot_start_[denseSlot(Cell(x0, y, c.z() + 1))],
             slot_start_[denseSlot(Cell(x1, y, c.z() + 1)) + 1]);
  }
}

void GridBroadphase::findPairsHashed(double margin, int begin, int end,
                                     std::vector<std::pair<int, int>>& pairs) const {
  const int dz = dimension_ == 3 ? 1 : 0;
  for (int k = begin; k < end; ++k) {
    const int i = sorted_[k];
    const Cell& ci = particle_cell_[i];
    const Vector3& center = sorted_center_[k];
    const double ri = sorted_radius_[k] + margin;
    for (int x = -1; x <= 1; ++x)
      for (int y = -1; y <= 1; ++y)
        for (int z = -dz; z <= dz; ++z) {
          const Cell neighbour = ci + Cell(x, y, z);
          const std::size_t s = hashSlot(neighbour);
          for (int m = slot_start_[s]; m < slot_start_[s + 1]; ++m) {
            const int j = sorted_[m];
            // other cells hashed to this slot are skipped; each pair is seen once, from i < j
            if (j <= i || particle_cell_[j] != neighbour) continue;
            const double reach = ri + sorted_radius_[m];
            if ((sorted_center_[m] - center).squaredNorm() < reach * reach)
              pairs.emplace_back(i, j);
          }
        }
  }
}

}  // namespace sweep
