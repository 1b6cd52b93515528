#include "contact/pair_search.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "contact/fcl_scene.hpp"
#include "framework/parallel.hpp"

namespace sweep {

void broadphaseGrid(const Model& model, const ContactModel& cmodel, ContactData& cdata,
                    const DetectionMargins& margins, double t, int threads) {
  const double margin = margins.balls;  // the grid holds balls only
  const int n = static_cast<int>(cdata.particles.size());
  double largest = 0.0;
  cdata.particle_center.resize(n);
  cdata.particle_radius.resize(n);
  for (int k = 0; k < n; ++k) {
    cdata.particle_center[k] = cdata.geometry_pose[cdata.particles[k]].translation;
    largest = std::max(largest, cdata.particle_radius[k]);
  }
  const double reach = 2.0 * largest + margin;
  // periodic boundaries: grains within reach of a boundary get an image beyond the other one
  cdata.ghost_of.clear();
  const Periodicity& periodic = cmodel.settings.periodic;
  if (periodic.enabled()) {
    if (!(2.0 * reach < periodic.period()))
      throw std::runtime_error("periodic detection: the search reach " + std::to_string(reach) +
                               " m exceeds half the period; the step is too large for it");
    for (int k = 0; k < n; ++k) {
      const double x = cdata.particle_center[k][periodic.axis];
      for (int image = 1; image <= 2; ++image) {
        const bool near = image == 1 ? x - periodic.low < reach : periodic.high - x < reach;
        if (!near) continue;
        cdata.ghost_of.emplace_back(k, image);
        cdata.particle_center.push_back(cdata.particle_center[k] + imageShift(periodic, image));
        cdata.particle_radius.push_back(cdata.particle_radius[k]);
      }
    }
  }
  cdata.grid.build(cdata.particle_center, cdata.particle_radius, reach, cmodel.dimension);
  const std::size_t first = cdata.pairs.size();
  cdata.grid.findPairs(margin, cdata.pairs, threads, &cdata.run_pairs);
  std::size_t kept = first;
  // a distributed run's rank keeps the pairs whose lowest owner rank is its own
  // (restrictParticles); a particle of no rank's (-1) leaves the verdict to the other side
  const bool by_rank = cdata.pair_rank >= 0;
  auto lowestRank = [&](int a, int b) {
    const int ra = cdata.particle_rank[a], rb = cdata.particle_rank[b];
    return ra < 0 ? rb : rb < 0 ? ra : std::min(ra, rb);
  };
  auto originalOf = [&](int k) { return k < n ? k : cdata.ghost_of[k - n].first; };
  for (std::size_t k = first; k < cdata.pairs.size(); ++k) {
    int i = cdata.pairs[k].first, j = cdata.pairs[k].second;
    if (i >= n && j >= n) continue;  // two images: the pair of their originals is found as is
    if (by_rank && lowestRank(originalOf(i), originalOf(j)) != cdata.pair_rank) continue;
    if (i < n && j < n) {
      i = cdata.particles[i];
      j = cdata.particles[j];
      cdata.pairs[kept++] = encodePair(std::min(i, j), std::max(i, j));
      continue;
    }
    if (i >= n) std::swap(i, j);
    // a grain against an image: found once from each side; kept where the image is of the
    // larger geometry
    const auto [original, image] = cdata.ghost_of[j - n];
    const int real = cdata.particles[i], imaged = cdata.particles[original];
    if (real < imaged) cdata.pairs[kept++] = encodePair(real, imaged, image);
  }
  cdata.pairs.resize(kept);
  // walls, blades, planes: against the particles their box can reach, and each other
  // a driven body past its removal time meets nothing: the narrowphase would drop its pairs
  auto removed = [&](int g) { return removedAt(model, cmodel, g, t); };
  for (std::size_t l = 0; l < cdata.large.size(); ++l) {
    const int g = cdata.large[l];
    if (removed(g)) continue;
    const Shape& shape = cmodel.geometries[g].shape;
    auto add = [&](int k) {
      if (k >= n) return;  // images meet only grains
      // another rank's grain: its contacts with the walls are that rank's
      if (by_rank && cdata.particle_rank[k] >= 0 && cdata.particle_rank[k] != cdata.pair_rank)
        return;
      const int p = cdata.particles[k];
      cdata.pairs.push_back(encodePair(std::min(g, p), std::max(g, p)));
    };
    if (isUnbounded(shape)) {
      // the grains within the margin of its face: the narrowphase's gap, with room for its
      // rounding. A powder bed's floor and end walls each met every grain, half the pairs.
      const Vector3 origin = cdata.geometry_pose[g].translation;
      const Vector3 outward = outwardNormal(shape, cdata.geometry_pose[g]);
      const double face_margin = std::max(margins.balls, margins.others);
      for (int k = 0; k < n; ++k) {
        const Vector3 offset = cdata.particle_center[k] - origin;
        const double radius = cdata.particle_radius[k];
        const double slack = 1e-9 * (offset.cwiseAbs().sum() + radius);
        // a NaN gap is kept: the narrowphase decides as before
        if (!(offset.dot(outward) - radius >= face_margin + slack)) add(k);
      }
    } else {
      const Vector3 center = cdata.geometry_pose[g].translation;
      // a large ball meets the particles with the balls' margin, which a check of the end
      // velocities may have raised above the other one
      const Vector3 half = boundingHalfWidths(shape, cdata.geometry_pose[g].rotation) +
                           Vector3::Constant(largest + std::max(margins.balls, margins.others));
      cdata.grid.query(center - half, center + half, add);
    }
    // the same pairs in the same order as over every m > l, skipping frozen-frozen ones
    const bool moving = cmodel.traits[g].moving;
    const auto first_moving =
        std::upper_bound(cdata.large_moving.begin(), cdata.large_moving.end(), static_cast<int>(l));
    const std::size_t count =
        moving ? cdata.large.size() - l - 1
               : static_cast<std::size_t>(cdata.large_moving.end() - first_moving);
    for (std::size_t k = 0; k < count; ++k) {
      const int other = cdata.large[moving ? l + 1 + k : first_moving[k]];
      if (cmodel.mayCollide(g, other) && !removed(other))
        cdata.pairs.push_back(encodePair(g, other));
    }
  }
}

void broadphaseFcl(const ContactModel& cmodel, ContactData& cdata,
                   const DetectionMargins& margins) {
  cdata.fcl->update(cdata.geometry_pose, std::max(margins.balls, margins.others));
  cdata.fcl->findPairs(cdata.pairs);
  for (auto& pair : cdata.pairs) pair = encodePair(pair.first, pair.second);
  // FCL holds no half-spaces: they meet every geometry
  for (int h = 0; h < cmodel.size(); ++h) {
    if (cdata.fcl->has(h)) continue;
    for (int g = 0; g < cmodel.size(); ++g)
      if (g != h && cmodel.mayCollide(g, h))
        cdata.pairs.push_back(encodePair(std::min(g, h), std::max(g, h)));
  }
}

// Sorts pairs (a < b): counting sort on a, then each run on b. A grain's run holds a
// handful of neighbours and is insertion-sorted; a plate's or a wall's holds every grain
// near it (thousands under a powder layer), where insertion sort was quadratic and took
// 80 % of detection (docs/powder_bed.md): those runs go to std::sort.
// On threads, the counting sort counts and scatters the pairs cut into one range per thread,
// range r's pairs of a geometry after range r - 1's: the stable order of one thread's scatter.
// Runs are sorted each on its own: on threads, the same order.
void sortPairs(int geometries, ContactData& cdata, int threads) {
  std::vector<int>& start = cdata.pair_start;
  const std::size_t pair_count = cdata.pairs.size();
  const bool parallel = threads > 1 && pair_count >= static_cast<std::size_t>(kParallelItems);
  const int ranges = parallel ? threads : 1;
  const std::size_t stride = static_cast<std::size_t>(geometries) + 1;
  // range r's count, then its cursor, of geometry g at range_start[r * stride + g + 1]
  std::vector<int>& range_start = cdata.pair_range_start;
  range_start.assign(ranges * stride, 0);
  cdata.sorted_pairs.resize(pair_count);
  const auto& unsorted = cdata.pairs;
  auto& sorted = cdata.sorted_pairs;
  auto countRange = [&](int r) {
    int* count = range_start.data() + r * stride;
    for (std::size_t k = runBegin(pair_count, r, ranges); k < runBegin(pair_count, r + 1, ranges);
         ++k)
      ++count[unsorted[k].first + 1];
  };
  auto placeRanges = [&] {
    // geometry g's pairs: range 0's, range 1's, ...; each range's cursor at its first slot
    int next = 0;
    for (int g = 0; g < geometries; ++g)
      for (int r = 0; r < ranges; ++r) {
        int& slot = range_start[r * stride + g + 1];
        const int count = slot;
        slot = next;
        next += count;
      }
  };
  auto scatterRange = [&](int r) {
    int* cursor = range_start.data() + r * stride;
    for (std::size_t k = runBegin(pair_count, r, ranges); k < runBegin(pair_count, r + 1, ranges);
         ++k)
      sorted[cursor[unsorted[k].first + 1]++] = unsorted[k];
  };
  if (parallel) {
#pragma omp parallel num_threads(ranges)
    {
#pragma omp for schedule(static, 1)
      for (int r = 0; r < ranges; ++r) countRange(r);
#pragma omp single
      placeRanges();
#pragma omp for schedule(static, 1)
      for (int r = 0; r < ranges; ++r) scatterRange(r);
    }
  } else {
    countRange(0);
    placeRanges();
    scatterRange(0);
  }
  // the end of each geometry's run: the last range's cursor after its scatter
  start.resize(stride);
  for (int g = 0; g < geometries; ++g) start[g] = range_start[(ranges - 1) * stride + g + 1];
  std::swap(cdata.pairs, cdata.sorted_pairs);
  auto& pairs = cdata.pairs;
  constexpr int kInsertionRun = 32;
  auto sortRun = [&](int g) {
    const int run_begin = g == 0 ? 0 : start[g - 1], run_end = start[g];
    if (run_end - run_begin > kInsertionRun) {
      // a plate's run comes in grain order already
      if (!std::is_sorted(pairs.begin() + run_begin, pairs.begin() + run_end))
        std::sort(pairs.begin() + run_begin, pairs.begin() + run_end);
    } else {
      for (int k = run_begin + 1; k < run_end; ++k)
        for (int m = k; m > run_begin && pairs[m] < pairs[m - 1]; --m)
          std::swap(pairs[m], pairs[m - 1]);
    }
  };
  if (parallel) {
#pragma omp parallel for schedule(dynamic, 1024) num_threads(threads)
    for (int g = 0; g < geometries; ++g) sortRun(g);
  } else {
    for (int g = 0; g < geometries; ++g) sortRun(g);
  }
}

}  // namespace sweep
