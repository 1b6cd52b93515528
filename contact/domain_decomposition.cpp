// The particles' domain decomposition over MPI ranks (domain_decomposition.hpp).
#include "contact/domain_decomposition.hpp"

#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string>

#include "framework/error.hpp"

namespace sweep {

namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// an integer carried bit for bit in a double of the exchange buffers
double bitsOf(std::int64_t value) {
  double bits;
  std::memcpy(&bits, &value, sizeof bits);
  return bits;
}
std::int64_t integerOf(double bits) {
  std::int64_t value;
  std::memcpy(&value, &bits, sizeof value);
  return value;
}

void check(int status, const char* call) {
  if (status == MPI_SUCCESS) return;
  std::fprintf(stderr, "sweep: %s failed (MPI error %d)\n", call, status);
  MPI_Abort(MPI_COMM_WORLD, 1);
}

// Every region g's cut at once, by histograms: the work in kBins bins across [lo, hi) along
// axis[g] (and below lo), summed over the ranks, gives the bin where the work below reaches
// target[g]; that bin is the next round's [lo, hi), and hi the cut in the end. Four rounds of
// 256 bins place a cut within 2.3e-10 of the region's extent for four all-reduces, where
// bisection took one each halving. group_of[i]: particle i's region, -1 for none.
void narrowCuts(const RankGroup& ranks, const ParticleSet& owned, const std::vector<int>& group_of,
                const std::vector<int>& axis, const std::vector<std::int64_t>& total,
                const std::vector<std::int64_t>& target, std::vector<double>& lo,
                std::vector<double>& hi) {
  constexpr int kBins = 256, kRounds = 4;
  const int stride = kBins + 1;  // slot 0: the work below lo
  const int m = static_cast<int>(axis.size());
  std::vector<std::int64_t> histogram(static_cast<std::size_t>(m) * stride);
  for (int round = 0; round < kRounds; ++round) {
    std::fill(histogram.begin(), histogram.end(), 0);
    for (int i = 0; i < owned.size(); ++i) {
      const int g = group_of[i];
      if (g < 0) continue;
      const double x = owned.position[i][axis[g]];
      if (!(x < hi[g])) continue;
      const double scaled = (x - lo[g]) / (hi[g] - lo[g]) * kBins;
      const int slot = x < lo[g] ? 0 : 1 + std::min(kBins - 1, static_cast<int>(scaled));
      histogram[static_cast<std::size_t>(g) * stride + slot] += owned.work[i];
    }
    ranks.sum(histogram);
    for (int g = 0; g < m; ++g) {
      if (total[g] == 0 || !(hi[g] > lo[g])) continue;  // no work: cut in the middle
      const std::int64_t* h = histogram.data() + static_cast<std::size_t>(g) * stride;
      std::int64_t below = h[0];
      int k = 0;
      while (k < kBins && below + h[1 + k] < target[g]) below += h[1 + k++];
      if (k == kBins) {  // short of the target below hi: the cut is hi
        lo[g] = hi[g];
        continue;
      }
      const double width = (hi[g] - lo[g]) / kBins;
      const double bin_lower = lo[g] + k * width;
      if (k < kBins - 1) hi[g] = lo[g] + (k + 1) * width;
      lo[g] = bin_lower;
    }
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// RankGroup, MpiSession

RankGroup RankGroup::world() {
  int initialized = 0, finalized = 0;
  MPI_Initialized(&initialized);
  MPI_Finalized(&finalized);
  if (!initialized || finalized) return RankGroup(0, 1, false);
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  return RankGroup(rank, size, true);
}

void RankGroup::sum(std::vector<std::int64_t>& values) const {
  if (!mpi_ || values.empty()) return;
  static_assert(sizeof(std::int64_t) == sizeof(long long), "int64 is MPI_LONG_LONG");
  check(MPI_Allreduce(MPI_IN_PLACE, values.data(), static_cast<int>(values.size()), MPI_LONG_LONG,
                      MPI_SUM, MPI_COMM_WORLD),
        "MPI_Allreduce");
}

void RankGroup::min(std::vector<double>& values) const {
  if (!mpi_ || values.empty()) return;
  check(MPI_Allreduce(MPI_IN_PLACE, values.data(), static_cast<int>(values.size()), MPI_DOUBLE,
                      MPI_MIN, MPI_COMM_WORLD),
        "MPI_Allreduce");
}

void RankGroup::max(std::vector<double>& values) const {
  if (!mpi_ || values.empty()) return;
  check(MPI_Allreduce(MPI_IN_PLACE, values.data(), static_cast<int>(values.size()), MPI_DOUBLE,
                      MPI_MAX, MPI_COMM_WORLD),
        "MPI_Allreduce");
}

void RankGroup::exchange(const std::vector<std::vector<double>>& send,
                         std::vector<std::vector<double>>& receive) const {
  receive.resize(size_);
  if (!mpi_) {
    receive[0].assign(send[0].begin(), send[0].end());
    return;
  }
  send_count_.resize(size_);
  receive_count_.resize(size_);
  send_offset_.assign(size_ + 1, 0);
  receive_offset_.assign(size_ + 1, 0);
  for (int r = 0; r < size_; ++r) {
    if (send[r].size() > static_cast<std::size_t>(std::numeric_limits<int>::max()))
      abort("sweep: a rank's exchange exceeds 2^31 doubles", 1);
    send_count_[r] = static_cast<int>(send[r].size());
  }
  check(MPI_Alltoall(send_count_.data(), 1, MPI_INT, receive_count_.data(), 1, MPI_INT,
                     MPI_COMM_WORLD),
        "MPI_Alltoall");
  for (int r = 0; r < size_; ++r) {
    send_offset_[r + 1] = send_offset_[r] + send_count_[r];
    receive_offset_[r + 1] = receive_offset_[r] + receive_count_[r];
  }
  packed_out_.resize(static_cast<std::size_t>(send_offset_[size_]));
  packed_in_.resize(static_cast<std::size_t>(receive_offset_[size_]));
  for (int r = 0; r < size_; ++r)
    std::copy(send[r].begin(), send[r].end(), packed_out_.begin() + send_offset_[r]);
  check(MPI_Alltoallv(packed_out_.data(), send_count_.data(), send_offset_.data(), MPI_DOUBLE,
                      packed_in_.data(), receive_count_.data(), receive_offset_.data(), MPI_DOUBLE,
                      MPI_COMM_WORLD),
        "MPI_Alltoallv");
  for (int r = 0; r < size_; ++r)
    receive[r].assign(packed_in_.begin() + receive_offset_[r],
                      packed_in_.begin() + receive_offset_[r + 1]);
}

int RankGroup::gatherCounts(int own, bool root_only) const {
  receive_count_.resize(size_);
  receive_offset_.assign(size_ + 1, 0);
  if (root_only)
    check(MPI_Gather(&own, 1, MPI_INT, receive_count_.data(), 1, MPI_INT, 0, MPI_COMM_WORLD),
          "MPI_Gather");
  else
    check(MPI_Allgather(&own, 1, MPI_INT, receive_count_.data(), 1, MPI_INT, MPI_COMM_WORLD),
          "MPI_Allgather");
  if (root_only && rank_ != 0) return 0;
  for (int r = 0; r < size_; ++r) receive_offset_[r + 1] = receive_offset_[r] + receive_count_[r];
  return receive_offset_[size_];
}

std::vector<double> RankGroup::gather(const std::vector<double>& values) const {
  std::vector<double> all;
  gather(values, all);
  return all;
}

void RankGroup::gather(const std::vector<double>& values, std::vector<double>& all) const {
  if (!mpi_) {
    all.assign(values.begin(), values.end());
    return;
  }
  const int own = static_cast<int>(values.size());
  all.resize(static_cast<std::size_t>(gatherCounts(own, false)));
  check(MPI_Allgatherv(values.data(), own, MPI_DOUBLE, all.data(), receive_count_.data(),
                       receive_offset_.data(), MPI_DOUBLE, MPI_COMM_WORLD),
        "MPI_Allgatherv");
}

void RankGroup::gatherEqual(const std::vector<double>& values, std::vector<double>& all) const {
  if (!mpi_) {
    all.assign(values.begin(), values.end());
    return;
  }
  const int own = static_cast<int>(values.size());
  all.resize(values.size() * static_cast<std::size_t>(size_));
  check(MPI_Allgather(values.data(), own, MPI_DOUBLE, all.data(), own, MPI_DOUBLE, MPI_COMM_WORLD),
        "MPI_Allgather");
}

void RankGroup::gatherOnRoot(const std::vector<double>& values, std::vector<double>& all) const {
  if (!mpi_) {
    all.assign(values.begin(), values.end());
    return;
  }
  const int own = static_cast<int>(values.size());
  all.resize(static_cast<std::size_t>(gatherCounts(own, true)));
  check(MPI_Gatherv(values.data(), own, MPI_DOUBLE, all.data(), receive_count_.data(),
                    receive_offset_.data(), MPI_DOUBLE, 0, MPI_COMM_WORLD),
        "MPI_Gatherv");
}

void RankGroup::broadcast(std::string& text, int root) const {
  if (!mpi_) return;
  int length = static_cast<int>(text.size());
  check(MPI_Bcast(&length, 1, MPI_INT, root, MPI_COMM_WORLD), "MPI_Bcast");
  text.resize(static_cast<std::size_t>(length));
  check(MPI_Bcast(text.data(), length, MPI_CHAR, root, MPI_COMM_WORLD), "MPI_Bcast");
}

void RankGroup::abort(const char* message, int code) const {
  std::fprintf(stderr, "%s\n", message);
  std::fflush(stderr);
  if (mpi_) MPI_Abort(MPI_COMM_WORLD, code);
  std::exit(code);
}

MpiSession::MpiSession(int& argc, char**& argv) {
  int provided = 0;
  check(MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided), "MPI_Init_thread");
}

MpiSession::~MpiSession() {
  MPI_Finalize();
}

// ---------------------------------------------------------------------------------------------
// ParticleSet

void ParticleSet::clear() {
  id.clear();
  position.clear();
  work.clear();
  payload.clear();
}

void ParticleSet::append(const ParticleSet& from, int i, const Vector3& shift) {
  id.push_back(from.id[i]);
  position.push_back(from.position[i] + shift);
  work.push_back(from.work[i]);
  const auto first = from.payload.begin() + static_cast<std::ptrdiff_t>(i) * payload_width;
  payload.insert(payload.end(), first, first + payload_width);
}

// ---------------------------------------------------------------------------------------------
// DomainDecomposition

DomainDecomposition::DomainDecomposition(const RankGroup& ranks,
                                         const DecompositionSettings& settings)
    : ranks_(ranks), settings_(settings) {
  const char* axis_name[3] = {"x", "y", "z"};
  if (settings.dimension != 2 && settings.dimension != 3)
    throw InputError("domain decomposition: dimension must be 2 or 3, got " +
                     std::to_string(settings.dimension));
  if (!(std::isfinite(settings.ghost_width) && settings.ghost_width >= 0.0))
    throw InputError("domain decomposition: ghost_width must be finite and >= 0, got " +
                     formatValue(settings.ghost_width));
  for (int a = 0; a < settings.dimension; ++a) {
    const double lo = settings.lower[a], hi = settings.upper[a];
    if (!(std::isfinite(lo) && std::isfinite(hi) && lo < hi))
      throw InputError(std::string("domain decomposition: the box along ") + axis_name[a] +
                       " must be finite with lower < upper, got [" + formatValue(lo) + ", " +
                       formatValue(hi) + "]");
    if (settings.periodic[a] && 2.0 * settings.ghost_width > hi - lo)
      throw InputError(std::string("domain decomposition: the period along ") + axis_name[a] +
                       " (" + formatValue(hi - lo) + ") is shorter than twice ghost_width (" +
                       formatValue(settings.ghost_width) + ")");
  }
  if (settings.dimension == 2 && settings.periodic[2])
    throw InputError("domain decomposition: a 2D domain cannot be periodic along z");
  // until the first balance rank 0's region is the whole domain, the others' empty
  nodes_.assign(1, Node{});
  region_lower_.assign(ranks_.size(), Vector3::Constant(kInfinity));
  region_upper_.assign(ranks_.size(), Vector3::Constant(-kInfinity));
  for (int a = 0; a < 3; ++a) {
    region_lower_[0][a] = settings.periodic[a] ? settings.lower[a] : -kInfinity;
    region_upper_[0][a] = settings.periodic[a] ? settings.upper[a] : kInfinity;
  }
  send_buffer_.resize(ranks_.size());
}

Vector3 DomainDecomposition::wrapped(const Vector3& position) const {
  Vector3 p = position;
  for (int a = 0; a < 3; ++a) {
    if (!settings_.periodic[a]) continue;
    const double lo = settings_.lower[a], period = settings_.upper[a] - lo;
    double x = std::fmod(p[a] - lo, period);
    if (x < 0.0) x += period;
    if (x >= period) x = 0.0;  // fmod's -tiny + period rounds to period
    p[a] = lo + x;
  }
  return p;
}

int DomainDecomposition::leafOf(const Vector3& p) const {
  int node = 0;
  while (nodes_[node].axis >= 0) {
    const Node& n = nodes_[node];
    node = n.child[p[n.axis] < n.cut ? 0 : 1];
  }
  return node;
}

int DomainDecomposition::owner(const Vector3& position) const {
  return nodes_[leafOf(wrapped(position))].rank;
}

void DomainDecomposition::region(int rank, Vector3& lower, Vector3& upper) const {
  lower = region_lower_.at(rank);
  upper = region_upper_.at(rank);
}

void DomainDecomposition::ranksMeeting(const Vector3& lo, const Vector3& hi,
                                       std::vector<int>& ranks) const {
  // depth-first, child 0 first: the ranks in increasing order
  int stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& n = nodes_[stack[--top]];
    if (n.axis < 0) {
      ranks.push_back(n.rank);
      continue;
    }
    if (hi[n.axis] >= n.cut) stack[top++] = n.child[1];
    if (lo[n.axis] < n.cut) stack[top++] = n.child[0];
  }
}

double DomainDecomposition::imbalance(const ParticleSet& owned) const {
  std::vector<std::int64_t> work(ranks_.size(), 0);
  for (std::int64_t w : owned.work) work[ranks_.rank()] += w;
  ranks_.sum(work);
  std::int64_t total = 0, most = 0;
  for (std::int64_t w : work) {
    total += w;
    most = std::max(most, w);
  }
  if (total == 0) return 1.0;
  return static_cast<double>(most) * ranks_.size() / static_cast<double>(total);
}

void DomainDecomposition::wrapAndCheckWork(ParticleSet& owned) const {
  // a bad work on one rank is refused on every rank: the others would wait in the cuts' sums
  const int n = owned.size();
  std::vector<std::int64_t> bad{0};
  std::vector<double> first_bad{kInfinity};
  for (int i = 0; i < n; ++i) {
    owned.position[i] = wrapped(owned.position[i]);
    if (owned.work[i] >= 1) continue;
    ++bad[0];
    first_bad[0] = std::min(first_bad[0], static_cast<double>(owned.id[i]));
  }
  ranks_.sum(bad);
  ranks_.min(first_bad);
  if (bad[0] > 0)
    throw InputError("domain decomposition: " + std::to_string(bad[0]) +
                     " particles have a work below 1, the first particle " +
                     formatValue(first_bad[0]) + "; work must be >= 1");
}

ExchangeStats DomainDecomposition::balance(ParticleSet& owned) {
  const int n = owned.size();
  wrapAndCheckWork(owned);
  // A region being cut: its node, its ranks [first, first + count), and the box the cut is
  // searched in (the domain's, cut by the cuts above).
  struct Region {
    int node, first, count;
    Vector3 lower, upper, search_lower, search_upper;
  };
  nodes_.assign(1, Node{});
  Region root{
      0, 0, ranks_.size(), Vector3::Zero(), Vector3::Zero(), settings_.lower, settings_.upper};
  for (int a = 0; a < 3; ++a) {
    root.lower[a] = settings_.periodic[a] ? settings_.lower[a] : -kInfinity;
    root.upper[a] = settings_.periodic[a] ? settings_.upper[a] : kInfinity;
  }
  std::vector<Region> level{root};
  std::vector<int> node_of(n, 0);  // each particle's region at this level
  std::vector<int> slot_of_node;   // a node's place in `cutting`, -1 when it is a leaf
  while (!level.empty()) {
    std::vector<Region> cutting, next;
    for (const Region& r : level) {
      if (r.count == 1) {
        nodes_[r.node].rank = r.first;
        region_lower_[r.first] = r.lower;
        region_upper_[r.first] = r.upper;
      } else {
        cutting.push_back(r);
      }
    }
    if (cutting.empty()) break;
    const int m = static_cast<int>(cutting.size());
    slot_of_node.assign(nodes_.size(), -1);
    std::vector<int> axis(m);
    std::vector<double> lo(m), hi(m);
    for (int g = 0; g < m; ++g) {
      slot_of_node[cutting[g].node] = g;
      int best = 0;
      for (int a = 1; a < settings_.dimension; ++a)
        if (cutting[g].search_upper[a] - cutting[g].search_lower[a] >
            cutting[g].search_upper[best] - cutting[g].search_lower[best])
          best = a;
      axis[g] = best;
      lo[g] = cutting[g].search_lower[best];
      hi[g] = cutting[g].search_upper[best];
    }
    // each region's work, then its target below the cut
    std::vector<std::int64_t> total(m, 0), target(m);
    for (int i = 0; i < n; ++i)
      if (slot_of_node[node_of[i]] >= 0) total[slot_of_node[node_of[i]]] += owned.work[i];
    ranks_.sum(total);
    for (int g = 0; g < m; ++g) target[g] = total[g] * (cutting[g].count / 2) / cutting[g].count;
    std::vector<int> group_of(n);  // each particle's region being cut, -1 for none
    for (int i = 0; i < n; ++i) group_of[i] = slot_of_node[node_of[i]];
    narrowCuts(ranks_, owned, group_of, axis, total, target, lo, hi);
    for (int g = 0; g < m; ++g) {
      const Region& r = cutting[g];
      const double cut =
          total[g] == 0 ? 0.5 * (r.search_lower[axis[g]] + r.search_upper[axis[g]]) : hi[g];
      const int left = static_cast<int>(nodes_.size());
      nodes_.push_back(Node{});
      nodes_.push_back(Node{});
      Node& node = nodes_[r.node];
      node.axis = axis[g];
      node.cut = cut;
      node.child[0] = left;
      node.child[1] = left + 1;
      Region below_cut = r, above_cut = r;
      below_cut.node = left;
      below_cut.count = r.count / 2;
      below_cut.upper[axis[g]] = below_cut.search_upper[axis[g]] = cut;
      above_cut.node = left + 1;
      above_cut.first = r.first + r.count / 2;
      above_cut.count = r.count - r.count / 2;
      above_cut.lower[axis[g]] = above_cut.search_lower[axis[g]] = cut;
      next.push_back(below_cut);
      next.push_back(above_cut);
    }
    for (int i = 0; i < n; ++i) {
      const Node& node = nodes_[node_of[i]];
      if (node.axis >= 0) node_of[i] = node.child[owned.position[i][node.axis] < node.cut ? 0 : 1];
    }
    level = std::move(next);
  }
  return migrate(owned);
}

void DomainDecomposition::pack(const ParticleSet& from, int i, const Vector3& shift, int rank) {
  std::vector<double>& out = send_buffer_[rank];
  const Vector3 p = from.position[i] + shift;
  out.push_back(bitsOf(from.id[i]));
  out.push_back(p.x());
  out.push_back(p.y());
  out.push_back(p.z());
  out.push_back(bitsOf(from.work[i]));
  const auto first = from.payload.begin() + static_cast<std::ptrdiff_t>(i) * from.payload_width;
  out.insert(out.end(), first, first + from.payload_width);
}

ExchangeStats DomainDecomposition::sendPacked(ParticleSet& into) {
  const std::size_t record = 5 + static_cast<std::size_t>(into.payload_width);
  ExchangeStats stats;
  for (int r = 0; r < ranks_.size(); ++r) {
    if (r == ranks_.rank()) continue;
    stats.particles += static_cast<std::int64_t>(send_buffer_[r].size() / record);
    stats.bytes += static_cast<std::int64_t>(send_buffer_[r].size() * sizeof(double));
  }
  ranks_.exchange(send_buffer_, receive_buffer_);
  for (std::vector<double>& buffer : send_buffer_) buffer.clear();
  for (const std::vector<double>& in : receive_buffer_) {
    if (in.size() % record != 0)
      ranks_.abort("sweep: an exchange of particles arrived with a record of another width", 1);
    for (std::size_t k = 0; k < in.size(); k += record) {
      into.id.push_back(integerOf(in[k]));
      into.position.emplace_back(in[k + 1], in[k + 2], in[k + 3]);
      into.work.push_back(integerOf(in[k + 4]));
      into.payload.insert(into.payload.end(), in.begin() + static_cast<std::ptrdiff_t>(k + 5),
                          in.begin() + static_cast<std::ptrdiff_t>(k + record));
    }
  }
  return stats;
}

ExchangeStats DomainDecomposition::migrate(ParticleSet& owned) {
  const int me = ranks_.rank(), n = owned.size();
  const int width = owned.payload_width;
  int kept = 0;
  for (int i = 0; i < n; ++i) {
    owned.position[i] = wrapped(owned.position[i]);
    const int to = nodes_[leafOf(owned.position[i])].rank;
    if (to != me) {
      pack(owned, i, Vector3::Zero(), to);
      continue;
    }
    if (kept != i) {  // compacted in place, in order
      owned.id[kept] = owned.id[i];
      owned.position[kept] = owned.position[i];
      owned.work[kept] = owned.work[i];
      std::copy_n(owned.payload.begin() + static_cast<std::ptrdiff_t>(i) * width, width,
                  owned.payload.begin() + static_cast<std::ptrdiff_t>(kept) * width);
    }
    ++kept;
  }
  owned.id.resize(kept);
  owned.position.resize(kept);
  owned.work.resize(kept);
  owned.payload.resize(static_cast<std::size_t>(kept) * width);
  return sendPacked(owned);
}

bool DomainDecomposition::setGhostWidth(double width) {
  if (!(std::isfinite(width) && width >= 0.0)) return false;
  for (int a = 0; a < 3; ++a)
    if (settings_.periodic[a] && 2.0 * width > settings_.upper[a] - settings_.lower[a])
      return false;
  settings_.ghost_width = width;
  return true;
}

ExchangeStats DomainDecomposition::exchangeGhosts(const ParticleSet& owned, ParticleSet& ghosts) {
  ghosts.clear();
  ghosts.payload_width = owned.payload_width;
  const int me = ranks_.rank();
  const double w = settings_.ghost_width;
  std::vector<int> ranks;
  for (int i = 0; i < owned.size(); ++i) {
    const Vector3 p = owned.position[i];
    // the shifts of the images near a periodic face: 0, and +-period along each such axis
    double shifts[3][2];
    int shift_count[3];
    for (int a = 0; a < 3; ++a) {
      shifts[a][0] = 0.0;
      shift_count[a] = 1;
      if (!settings_.periodic[a]) continue;
      const double period = settings_.upper[a] - settings_.lower[a];
      if (p[a] - settings_.lower[a] < w)
        shifts[a][shift_count[a]++] = period;
      else if (settings_.upper[a] - p[a] <= w)
        shifts[a][shift_count[a]++] = -period;
    }
    for (int sx = 0; sx < shift_count[0]; ++sx)
      for (int sy = 0; sy < shift_count[1]; ++sy)
        for (int sz = 0; sz < shift_count[2]; ++sz) {
          const Vector3 shift(shifts[0][sx], shifts[1][sy], shifts[2][sz]);
          const Vector3 q = p + shift;
          ranks.clear();
          ranksMeeting(q - Vector3::Constant(w), q + Vector3::Constant(w), ranks);
          const bool image = sx + sy + sz > 0;
          for (int r : ranks) {
            if (r == me && !image) continue;
            if (r == me) {
              ghosts.append(owned, i, shift);
            } else {
              pack(owned, i, shift, r);
            }
          }
        }
  }
  return sendPacked(ghosts);
}

}  // namespace sweep
