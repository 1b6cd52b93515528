// The particles' domain decomposition over ranks (contact/domain_decomposition.hpp). The same
// binary runs on 1 to 4 ranks (tests/CMakeLists.txt: mpiexec -n N); every test calls the
// collectives in the same order on every rank and checks with EXPECT (never returning early),
// so a failure on one rank cannot leave the others waiting.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <set>
#include <tuple>

#include "contact/domain_decomposition.hpp"
#include "framework/error.hpp"

namespace sweep {
namespace {

// A bed like the powder layer's: long along x (periodic), narrow along y, thin along z; the
// grains crowd at one end (x = L u^2), so that an even split by count is not one by volume.
DecompositionSettings bedSettings(int dimension) {
  DecompositionSettings s;
  s.dimension = dimension;
  s.lower = Vector3(0.0, 0.0, 0.0);
  s.upper = Vector3(2e-3, 0.5e-3, dimension == 3 ? 0.3e-3 : 0.0);
  if (dimension == 2) s.upper.z() = 1.0;  // unused: no cut along z in 2D
  s.periodic = {{true, false, false}};
  s.ghost_width = 50e-6;  // two 20 um radii and a 10 um margin
  return s;
}

ParticleSet crowdedBed(const RankGroup& ranks, const DecompositionSettings& s, int per_rank,
                       int payload_width = 2) {
  std::mt19937_64 random(1234 + 17 * ranks.rank());
  std::uniform_real_distribution<double> u(0.0, 1.0);
  ParticleSet set;
  set.payload_width = payload_width;
  for (int k = 0; k < per_rank; ++k) {
    const std::int64_t id = static_cast<std::int64_t>(ranks.rank()) * per_rank + k;
    const double a = u(random);
    Vector3 p(s.upper.x() * a * a, s.upper.y() * u(random),
              s.dimension == 3 ? s.upper.z() * u(random) : 0.0);
    set.id.push_back(id);
    set.position.push_back(p);
    set.work.push_back(1 + id % 5);
    for (int j = 0; j < payload_width; ++j) set.payload.push_back(static_cast<double>(id) + j);
  }
  return set;
}

std::int64_t total(const RankGroup& ranks, std::int64_t value) {
  std::vector<std::int64_t> v{value};
  ranks.sum(v);
  return v[0];
}

// the displacement from a to b, the nearest image along the periodic axes
Vector3 nearest(const DecompositionSettings& s, const Vector3& a, const Vector3& b) {
  Vector3 d = b - a;
  for (int k = 0; k < 3; ++k) {
    if (!s.periodic[k]) continue;
    const double period = s.upper[k] - s.lower[k];
    d[k] -= period * std::round(d[k] / period);
  }
  return d;
}

bool boxMeetsRegion(const Vector3& q, double w, const Vector3& lo, const Vector3& hi) {
  for (int k = 0; k < 3; ++k)
    if (!(q[k] + w >= lo[k] && q[k] - w < hi[k])) return false;
  return true;
}

TEST(DomainDecomposition, BalanceSplitsTheWorkAndKeepsEveryParticle) {
  const RankGroup ranks = RankGroup::world();
  for (int dimension : {2, 3}) {
    const DecompositionSettings s = bedSettings(dimension);
    DomainDecomposition dd(ranks, s);
    ParticleSet owned = crowdedBed(ranks, s, 3000);
    std::int64_t id_sum = 0, payload_mismatch = 0;
    for (std::int64_t id : owned.id) id_sum += id;
    dd.balance(owned);
    // every particle once, with its own payload
    EXPECT_EQ(total(ranks, owned.size()), 3000L * ranks.size());
    std::int64_t id_sum_after = 0;
    for (int i = 0; i < owned.size(); ++i) {
      id_sum_after += owned.id[i];
      for (int j = 0; j < owned.payload_width; ++j)
        if (owned.payload[i * owned.payload_width + j] != static_cast<double>(owned.id[i]) + j)
          ++payload_mismatch;
    }
    EXPECT_EQ(total(ranks, id_sum_after), total(ranks, id_sum));
    EXPECT_EQ(payload_mismatch, 0);
    // each where it belongs, and the work split to within a few particles' worth
    Vector3 lo, hi;
    dd.region(ranks.rank(), lo, hi);
    int misplaced = 0;
    for (int i = 0; i < owned.size(); ++i) {
      const Vector3& p = owned.position[i];
      if (dd.owner(p) != ranks.rank()) ++misplaced;
      for (int k = 0; k < dimension; ++k)
        if (!(p[k] >= lo[k] && p[k] < hi[k])) ++misplaced;
    }
    EXPECT_EQ(misplaced, 0);
    EXPECT_LE(dd.imbalance(owned), 1.01) << "dimension " << dimension;
  }
}

// The property ghosts exist for: every pair within ghost_width is whole on the rank of each of
// its particles, at the right periodic image; and no ghost lies farther than ghost_width from
// the rank's region.
TEST(DomainDecomposition, GhostsHoldEveryNeighbourOfEveryOwnedParticle) {
  const RankGroup ranks = RankGroup::world();
  for (int dimension : {2, 3}) {
    const DecompositionSettings s = bedSettings(dimension);
    DomainDecomposition dd(ranks, s);
    ParticleSet owned = crowdedBed(ranks, s, 1500, 0), ghosts;
    dd.balance(owned);
    dd.exchangeGhosts(owned, ghosts);
    // every particle, on every rank
    std::vector<double> mine;
    for (int i = 0; i < owned.size(); ++i) {
      mine.push_back(static_cast<double>(owned.id[i]));
      for (int k = 0; k < 3; ++k) mine.push_back(owned.position[i][k]);
    }
    const std::vector<double> all = ranks.gather(mine);
    std::multimap<std::int64_t, Vector3> here;
    for (int i = 0; i < owned.size(); ++i) here.emplace(owned.id[i], owned.position[i]);
    for (int i = 0; i < ghosts.size(); ++i) here.emplace(ghosts.id[i], ghosts.position[i]);
    long missing = 0, pairs = 0;
    for (int i = 0; i < owned.size(); ++i)
      for (std::size_t j = 0; j < all.size(); j += 4) {
        const auto id = static_cast<std::int64_t>(all[j]);
        if (id == owned.id[i]) continue;
        const Vector3 d =
            nearest(s, owned.position[i], Vector3(all[j + 1], all[j + 2], all[j + 3]));
        if (d.norm() > s.ghost_width) continue;
        ++pairs;
        const Vector3 expected = owned.position[i] + d;
        bool found = false;
        auto [first, last] = here.equal_range(id);
        for (auto it = first; it != last; ++it)
          found = found || (it->second - expected).norm() < 1e-12;
        if (!found) ++missing;
      }
    EXPECT_GT(total(ranks, pairs), 1000) << "the bed must be crowded enough to test anything";
    EXPECT_EQ(missing, 0) << "dimension " << dimension << ", rank " << ranks.rank();
    Vector3 lo, hi;
    dd.region(ranks.rank(), lo, hi);
    long far = 0;
    std::set<std::tuple<std::int64_t, double, double, double>> distinct;
    for (int i = 0; i < ghosts.size(); ++i) {
      const Vector3& q = ghosts.position[i];
      if (!boxMeetsRegion(q, s.ghost_width, lo, hi)) ++far;
      distinct.emplace(ghosts.id[i], q.x(), q.y(), q.z());
    }
    EXPECT_EQ(far, 0);
    EXPECT_EQ(distinct.size(), static_cast<std::size_t>(ghosts.size())) << "a ghost sent twice";
  }
}

// One grain travels one and a half periods along x and across y: it has one owner at every
// step, visits every rank, and its ghosts are on exactly the ranks (and images) within reach.
TEST(DomainDecomposition, AGrainCrossingEveryBoundaryHasOneOwnerAndItsGhosts) {
  const RankGroup ranks = RankGroup::world();
  const DecompositionSettings s = bedSettings(3);
  DomainDecomposition dd(ranks, s);
  ParticleSet background = crowdedBed(ranks, s, 2000, 0);
  dd.balance(background);
  ParticleSet grain, ghosts;
  grain.payload_width = 1;
  auto path = [&](int step) {
    const double t = step / 400.0;
    return Vector3(0.1e-3 + 1.5 * s.upper.x() * t, s.upper.y() * (0.05 + 0.9 * t), 0.15e-3);
  };
  if (ranks.rank() == 0) {
    grain.id = {42};
    grain.position = {path(0)};
    grain.work = {1};
    grain.payload = {3.5};
  }
  std::set<int> visited;
  long wrong_owner = 0, wrong_ghosts = 0, lost = 0;
  for (int step = 0; step <= 400; ++step) {
    for (Vector3& p : grain.position) p = path(step);  // the holder moves it
    dd.migrate(grain);
    const int owner = dd.owner(path(step));
    visited.insert(owner);
    if (total(ranks, grain.size()) != 1) ++lost;
    if ((grain.size() == 1) != (owner == ranks.rank())) ++wrong_owner;
    if (grain.size() == 1 && grain.payload[0] != 3.5) ++lost;
    dd.exchangeGhosts(grain, ghosts);
    // expected: the images within ghost_width of this rank's region, but the owner's own
    Vector3 lo, hi;
    dd.region(ranks.rank(), lo, hi);
    const double period = s.upper.x() - s.lower.x();
    Vector3 wrapped = path(step);
    wrapped.x() = std::fmod(wrapped.x(), period);
    int expected = 0;
    for (int image = -1; image <= 1; ++image) {
      const Vector3 q = wrapped + Vector3(image * period, 0.0, 0.0);
      if (image == 0 && owner == ranks.rank()) continue;
      if (boxMeetsRegion(q, s.ghost_width, lo, hi)) ++expected;
    }
    if (ghosts.size() != expected) ++wrong_ghosts;
  }
  EXPECT_EQ(lost, 0);
  EXPECT_EQ(wrong_owner, 0);
  EXPECT_EQ(wrong_ghosts, 0);
  EXPECT_EQ(static_cast<int>(visited.size()), ranks.size());
}

TEST(DomainDecomposition, TheSameInputGivesTheSameBits) {
  const RankGroup ranks = RankGroup::world();
  const DecompositionSettings s = bedSettings(3);
  ParticleSet owned[2], ghosts[2];
  for (int run = 0; run < 2; ++run) {
    DomainDecomposition dd(ranks, s);
    owned[run] = crowdedBed(ranks, s, 2000);
    dd.balance(owned[run]);
    dd.exchangeGhosts(owned[run], ghosts[run]);
  }
  EXPECT_EQ(owned[0].id, owned[1].id);
  EXPECT_EQ(owned[0].payload, owned[1].payload);
  EXPECT_EQ(ghosts[0].id, ghosts[1].id);
  EXPECT_TRUE(std::equal(ghosts[0].position.begin(), ghosts[0].position.end(),
                         ghosts[1].position.begin(), ghosts[1].position.end(),
                         [](const Vector3& a, const Vector3& b) { return a == b; }));
}

// A work below 1 on one rank's particle is refused on every rank, none left waiting.
TEST(DomainDecomposition, ABadWorkOnOneRankIsRefusedOnEvery) {
  const RankGroup ranks = RankGroup::world();
  DomainDecomposition dd(ranks, bedSettings(3));
  ParticleSet owned = crowdedBed(ranks, bedSettings(3), 100);
  if (ranks.rank() == ranks.size() - 1) owned.work[7] = 0;
  std::string message;
  try {
    dd.balance(owned);
  } catch (const InputError& e) {
    message = e.what();
  }
  const std::int64_t bad_id = (ranks.size() - 1) * 100L + 7;
  EXPECT_NE(
      message.find("1 particles have a work below 1, the first particle " + std::to_string(bad_id)),
      std::string::npos)
      << message;
}

TEST(DomainDecomposition, SettingsThatCannotWorkAreRefusedByName) {
  const RankGroup ranks = RankGroup::world();
  auto message = [&](DecompositionSettings s) -> std::string {
    try {
      DomainDecomposition dd(ranks, s);
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  DecompositionSettings s = bedSettings(3);
  s.ghost_width = 1.5e-3;  // more than half the 2 mm period
  EXPECT_NE(message(s).find("period along x"), std::string::npos) << message(s);
  s = bedSettings(3);
  s.ghost_width = -1.0;
  EXPECT_NE(message(s).find("ghost_width"), std::string::npos);
  s = bedSettings(3);
  s.upper.y() = s.lower.y();
  EXPECT_NE(message(s).find("along y"), std::string::npos);
  s = bedSettings(3);
  s.dimension = 4;
  EXPECT_NE(message(s).find("dimension"), std::string::npos);
}

}  // namespace
}  // namespace sweep

int main(int argc, char** argv) {
  sweep::MpiSession mpi(argc, argv);
  ::testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
