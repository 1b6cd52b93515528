#pragma once
// Domain decomposition of a scene's particles over MPI ranks (issue #49), the layer a
// distributed run stands on: who owns each particle, which copies each rank needs of its
// neighbours' particles, and the moves between them. MPI itself stays in
// domain_decomposition.cpp; this header names none of it.
//
// - The partition is a recursive coordinate bisection weighted by work (Berger & Bokhari 1987,
//   "A partitioning strategy for nonuniform problems on multiprocessors", IEEE Trans. Comput.
//   36; the balancer of Zoltan and of LAMMPS's `balance rcb`): a region of k ranks is cut
//   across its longest axis where the work below the cut is floor(k / 2) / k of the region's,
//   and each side is cut again. Work is an integer per particle (1 plus its contacts, say),
//   so the sums are exact and every rank finds the same cuts, whatever the order of its
//   particles. The cuts of one level are found together from histograms of the work along
//   their axes: four all-reduces a level.
// - A particle belongs to the region that holds its centre; the outer faces of a non-periodic
//   domain reach to infinity (a grain that leaves the box stays owned). Along a periodic axis
//   the centre is first wrapped into the period [lower, upper).
// - Ghosts: a rank receives a copy of every particle, or periodic image of one, whose centre
//   lies within ghost_width of its region (per axis: the centre's box of half-width
//   ghost_width meets the region). With ghost_width the largest centre distance at which two
//   particles interact (the largest diameter plus the detection margin), every pair that
//   interacts is seen whole by the owner of each of its particles. This is LAMMPS's ghost
//   cutoff (`comm_modify cutoff`), sent all at once rather than by its six-way swaps, so a
//   copy reaches every rank it meets in one exchange.
// - Migration sends each particle whose owner changed to that owner. Arrivals are appended in
//   rank order after the particles that stay, in their order: the same layout for the same
//   input and rank count.
// Only particles (free bodies) are decomposed. Walls, driven bodies and URDF trees are few
// and are meant to be held by every rank.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "framework/spatial.hpp"

namespace sweep {

// A set of ranks: MPI_COMM_WORLD, or one rank alone where MPI is not running.
class RankGroup {
 public:
  // MPI_COMM_WORLD where MPI is initialized (MpiSession); otherwise this process alone.
  static RankGroup world();
  int rank() const { return rank_; }
  int size() const { return size_; }

  // Collectives: every rank calls them in the same order.
  void sum(std::vector<std::int64_t>& values) const;  // element by element, in place
  void min(std::vector<double>& values) const;
  void max(std::vector<double>& values) const;
  // Sends send[r] to rank r (send.size() == size()); receive[r] is what rank r sent here.
  void exchange(const std::vector<std::vector<double>>& send,
                std::vector<std::vector<double>>& receive) const;
  // Every rank's values, concatenated in rank order.
  std::vector<double> gather(const std::vector<double>& values) const;
  // The same into `all`, whose storage is reused: no allocation once it has grown.
  void gather(const std::vector<double>& values, std::vector<double>& all) const;
  // The same where every rank passes as many values: one collective instead of two (the
  // counts need not travel), for the sums a solve takes every sweep.
  void gatherEqual(const std::vector<double>& values, std::vector<double>& all) const;
  // Every rank's values, concatenated in rank order, on rank 0 only (the others get `all`
  // empty): what one writer needs, without a copy of everything on every rank.
  void gatherOnRoot(const std::vector<double>& values, std::vector<double>& all) const;
  // Rank `root`'s text, on every rank.
  void broadcast(std::string& text, int root) const;
  // Ends every rank: prints message on this rank's standard error, then MPI_Abort(code).
  [[noreturn]] void abort(const char* message, int code) const;

 private:
  RankGroup(int rank, int size, bool mpi) : rank_(rank), size_(size), mpi_(mpi) {}
  // every rank's count into receive_count_ and their offsets (on rank 0 only when root_only);
  // returns the total this rank receives
  int gatherCounts(int own, bool root_only) const;
  int rank_ = 0, size_ = 1;
  bool mpi_ = false;  // false: one process without MPI, whose collectives are local
  // the collectives' counts and packed buffers, reused from call to call: a solve that
  // exchanges every sweep allocates nothing once they have grown
  mutable std::vector<int> send_count_, receive_count_, send_offset_, receive_offset_;
  mutable std::vector<double> packed_out_, packed_in_;
};

// MPI_Init_thread (funneled: OpenMP threads inside a rank do not call MPI) for the life of the
// object, and MPI_Finalize after; one per process, in main.
class MpiSession {
 public:
  MpiSession(int& argc, char**& argv);
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;
};

// Particles as a rank holds them, one entry per particle in each array.
struct ParticleSet {
  std::vector<std::int64_t> id;    // global and unique
  std::vector<Vector3> position;   // the centre
  std::vector<std::int64_t> work;  // >= 1: the balance's weight
  int payload_width = 0;           // doubles of the caller's state per particle
  std::vector<double> payload;     // payload_width per particle, moved with it unread

  int size() const { return static_cast<int>(id.size()); }
  void clear();
  // particle i of `from`, its centre moved by `shift`
  void append(const ParticleSet& from, int i, const Vector3& shift = Vector3::Zero());
};

struct DecompositionSettings {
  int dimension = 3;  // 2: cut across x and y only
  // The domain's box. Along a periodic axis, the period [lower, upper); along the others, where
  // the first cuts are searched (outside it a centre still has an owner).
  Vector3 lower = Vector3::Zero(), upper = Vector3::Ones();
  std::array<bool, 3> periodic{{false, false, false}};
  double ghost_width = 0.0;  // the largest centre distance at which two particles interact
};

// What one exchange sent from this rank.
struct ExchangeStats {
  std::int64_t particles = 0;
  std::int64_t bytes = 0;
};

class DomainDecomposition {
 public:
  // Throws InputError naming the field when the settings cannot be used (an empty box, a
  // negative ghost width, a period shorter than twice the ghost width, a dimension not 2 or 3).
  DomainDecomposition(const RankGroup& ranks, const DecompositionSettings& settings);

  // Collective. Cuts the domain by the work of the particles every rank holds now, then
  // migrates them to their owners. Until the first balance rank 0 owns the whole domain.
  ExchangeStats balance(ParticleSet& owned);
  // Collective. Wraps the centres into the period and sends each particle whose owner changed.
  ExchangeStats migrate(ParticleSet& owned);
  // Collective. ghosts gets the copies this rank needs (ghost copies, images shifted by the
  // period); it may hold images of this rank's own particles along a periodic axis.
  ExchangeStats exchangeGhosts(const ParticleSet& owned, ParticleSet& ghosts);

  // The rank that owns a centre (wrapped along the periodic axes first).
  int owner(const Vector3& position) const;
  // Rank r's region; along a non-periodic axis its outer faces are infinite.
  void region(int rank, Vector3& lower, Vector3& upper) const;
  // Collective: the most work on one rank over the mean (1 is perfect balance).
  double imbalance(const ParticleSet& owned) const;
  const DecompositionSettings& settings() const { return settings_; }
  // The next ghost exchanges' width; false (and the width kept) where a periodic axis's
  // period is shorter than twice that width. Every rank must pass the same width.
  bool setGhostWidth(double width);

 private:
  struct Node {
    int axis = -1;     // -1: a leaf, owned by `rank`
    double cut = 0.0;  // centres below it go to child[0]
    int child[2] = {-1, -1};
    int rank = 0;
  };
  Vector3 wrapped(const Vector3& position) const;
  // wraps the centres into the period; a work below 1 on any rank throws on every rank (the
  // others would wait in the cuts' sums)
  void wrapAndCheckWork(ParticleSet& owned) const;
  int leafOf(const Vector3& wrapped_position) const;
  // the ranks whose region meets the box [lo, hi]
  void ranksMeeting(const Vector3& lo, const Vector3& hi, std::vector<int>& ranks) const;
  // particle i of `from`, moved by shift, into send_buffer_[rank]
  void pack(const ParticleSet& from, int i, const Vector3& shift, int rank);
  // sends send_buffer_ and appends what arrives to `into`, in rank order
  ExchangeStats sendPacked(ParticleSet& into);

  RankGroup ranks_;
  DecompositionSettings settings_;
  std::vector<Node> nodes_;  // nodes_[0]: the root
  std::vector<Vector3> region_lower_, region_upper_;
  // exchange buffers, kept between calls
  std::vector<std::vector<double>> send_buffer_, receive_buffer_;
};

}  // namespace sweep
