#pragma once
// Both schemes (time_stepper.hpp) over MPI ranks: each rank steps the particles it
// owns (contact/domain_decomposition.hpp) and solves the contacts whose lowest owner rank it
// is (a contact across a cut goes to the lower rank). A body the rows of several ranks move
// (a shared body) is solved in one of two ways (RankInterface):
//
// - Ordered sweeps (the default): the single process's NLGS in another row order. Each sweep
//   takes every rank's interior rows (on bodies no other rank touches) at once, then the rows
//   on shared bodies colour by colour of a greedy colouring of the ranks (two ranks that touch
//   one body differ in colour), each colour sending the new velocities of the shared bodies
//   its rows moved to their other holders before the next colour sweeps. The masses, the
//   NNCG momentum (with the sweep's change summed over the ranks) and the stopping test are
//   the single process's, and so are the sweep counts: 42.5 against 41.5 a step on the powder
//   heap (docs/benchmarks.md, "Scheme A over ranks"). The interface rows of different colours
//   wait for each other: a serial part that grows with the cut surfaces.
// - Split masses: the nonsmooth contact domain decomposition (NSCDD) of Visseq, Martin,
//   Iceta, Azema, Dureisseix & Alart, "Distributed nonsmooth contact domain decomposition
//   (NSCDD): algorithmic structure and scalability" (Domain Decomposition Methods in Science
//   and Engineering XXI, 2014), after Barboteu, Alart & Dureisseix (2001). A body touched by
//   n_b ranks takes mass m_b / n_b on each; rank s sweeps from v_in,s = v_b - c_b,s, where
//   c_b,s = n_b M_b^-1 H_s^T P_s is its own rows' push, and the owner glues the copies after
//   every sweeps_per_exchange sweeps:
//     v_b = v_free,b + (1 / n_b) sum_s c_b,s = v_free,b + M_b^-1 sum_s H_s^T P_s.
//   Every rank sweeps at once, but the glue converges slowly: about twice the single
//   process's sweeps on the heap.
// Both stop on the single process's test: the relative natural-map residual of every rank's
// rows, summed over the ranks in rank order, below the solver's tolerance. Both apply the
// warm start (the last step's impulses) and add every rank's part of it on the shared bodies
// before the first sweep. One rank runs the plain step.
//
// Scheme B (the staggered scheme of Charles, Casenave & Glocker 2018) runs both of its stages
// as ordered sweeps, each from its own warm start glued as above: stage 5a's NLGS on the
// normal rows, then stage 5b's on the friction rows with the thresholds of 5a's impulses. Its
// projection of v1 on the closed normals (convex_stages.hpp) is conjugate gradients across the
// ranks: each product scatters the rank's rows onto its bodies, sums the shared bodies' parts
// over their ranks in rank order, and gathers; the dot products are sums over the ranks. The
// stages take NLGS on ranks (`auto`: with NNCG, as the single process takes it on grains).
//
// Each step: the owners move with their particles (migration; the domain cut again by work
// when the balance has gone, DistributedSettings), the last step's contacts whose owner changed
// go to the new owner with their impulses (warm starts), the copies within ghost_width of a
// rank's region arrive with q and v (ghost exchange), and detection bins the owned and ghost
// grains only, and the passes over the body trees (kinematics, dynamics, integration) visit
// those grains only (Data::componentSubset). Every rank holds the whole Model and state
// vectors; what it does not own or see is at rest and stale.
//
// Scope: 3D scenes whose bodies with dofs are all free spheres, or 2D scenes whose bodies with
// dofs are all free disks (ordered sweeps only); walls, plates, blades and other driven or
// fixed shapes are held by every rank. Both schemes (scheme B with ordered sweeps), with:
//   - adhesion: each adhesive row's -h F is part of its rank's push on shared bodies;
//   - candidate screening: every rank repeats a round when any rank admitted a candidate;
//   - detection margins and the margin check after the solve (detection.verify_margin) from
//     the whole scene's speeds, the ranks' owned grains combined: every rank detects with the
//     single process's margins, and all detect again when those fall short; the ghost band
//     follows the margin (DistributedSettings::ghost_width).
// No position projection, actuators, joint limits, systems or constraints; the constructor
// says which field is not supported.
#include <chrono>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "contact/domain_decomposition.hpp"
#include "integrators/friction_stage.hpp"
#include "integrators/step_data.hpp"
#include "integrators/sweeps.hpp"

namespace sweep {

// A failure that every rank of a collective call throws alike, with the same message: the
// caller may end the run on every rank without MPI_Abort.
class CollectiveError : public std::runtime_error {
 public:
  explicit CollectiveError(const std::string& message) : std::runtime_error(message) {}
};

// How the contacts of several ranks on one body are solved together.
enum class RankInterface {
  // Gauss-Seidel in an order across ranks: each sweep takes every rank's interior rows (those
  // on bodies no other rank's contacts touch) at once, then the rows on shared bodies rank
  // colour by rank colour (no two ranks of a colour touch one body), each colour's new
  // velocities of the shared bodies sent to their other holders before the next: the single
  // process's sweep in another row order, with its masses and its sweep counts.
  OrderedSweeps,
  // NSCDD (above): split masses, sweeps on every rank at once, glued by averaging.
  SplitMasses,
};

struct DistributedSettings {
  RankInterface interface = RankInterface::OrderedSweeps;
  // split masses: NLGS sweeps between two glues of the shared bodies (5 is the fastest of 2,
  // 5 and 10 on the powder heap)
  int sweeps_per_exchange = 5;
  // steps between two checks of the balance; 0: balanced at reset only. At a check the ranks
  // cut the domain again by work when the most work on one rank exceeds rebalance_above times
  // the mean (0: at every check). Grains settling into a heap, or a heap a blade carries,
  // leave the cuts of the start behind: one of two ranks ends with nearly every grain.
  int rebalance_interval = 10;
  double rebalance_above = 1.2;
  // the band of ghost copies about a rank's region (m): at least the largest centre distance
  // of two grains that may touch within a step; 0: twice the largest diameter. A step whose
  // detection margin plus the largest diameter exceeds it takes its ghosts again from a band
  // kGhostSlack times as wide, and the next step starts from that band.
  double ghost_width = 0.0;
};

// What the last step moved between ranks and how its solve went, summed over the ranks.
struct DistributedStats {
  std::int64_t bytes_sent = 0;     // migration, ghosts and glue messages
  std::int64_t shared_bodies = 0;  // bodies touched by the contacts of more than one rank
  int exchanges = 0;        // of the shared bodies' velocities: per colour and sweep, or glues
  int ghost_widenings = 0;  // ghost exchanges again from a wider band (0 or 1 a step)
  // split masses: the largest |v copy - v glued| of the last glue (m/s; a spin difference
  // times the largest radius)
  double mismatch = 0.0;
  double imbalance = 1.0;  // the most owned grains on one rank over the mean
  // contacts of the step found in the last step's (warm start and tangent frame carried), and
  // the last step's contacts sent to the rank that owns them now (migration, rebalances)
  std::int64_t carried = 0, handed_over = 0;
};

class DistributedStepper {
 public:
  // Collective. InputError naming the field for a scene or setting outside the scope above.
  DistributedStepper(const RankGroup& ranks, const Model& model, const ContactModel& cmodel,
                     const SchemeSettings& settings, const DistributedSettings& distributed = {});

  // Collective; every rank passes the same whole state.
  void reset(double t, const VectorX& q, const VectorX& v);
  // Collective. The stats are the whole scene's, summed (or the largest) over the ranks,
  // except the timings, which are this rank's. A body that runs away (RunawayError) or a state
  // no longer finite (CollectiveError) on any rank throws on every rank, with the message of
  // the lowest rank that found it; so does a ghost width too small for the margin. Any
  // other exception from one rank's step (a periodic reach beyond half the period) leaves the
  // others waiting in a collective: the caller ends the job with RankGroup::abort.
  const StepStats& step();
  // Collective: the whole state, each body as its owner holds it, on every rank.
  void gatherState(VectorX& q, VectorX& v) const;
  // Collective: every rank's contacts of the last step and their impulses, on rank 0 (the
  // others get them empty); what a snapshot of the contact network draws.
  void gatherContacts(std::vector<Contact>& contacts, std::vector<Vector3>& impulses) const;

  double time() const { return d_.t; }
  int ownedCount() const { return owned_.size(); }
  const DistributedStats& distributedStats() const { return dstats_; }
  const StepStats& stats() const { return d_.stats; }

 private:
  void refreshOwnership();
  void receiveGhosts();
  void findSharedBodies();
  void splitMasses(bool split);
  void solveAcrossRanks();
  void glue(const VectorX& v_free, VectorX& v, double& mismatch);
  void colourRanks();
  // v_free kept, the last step's impulses applied, and every rank's part of them added on the
  // shared bodies; returns the glue's mismatch
  double startFromWarmStart(VectorX& v);
  // a stage's start: v kept as the stage's base, warm(v) applies this rank's warm start, and
  // every rank's part of it is added on the shared bodies; returns the glue's mismatch
  double startStage(VectorX& v, const std::function<void(VectorX&)>& warm);
  // the assembled rows split for the ordered sweeps: interior and interface, and the turns
  void splitRowsForTurns();
  // The ordered sweeps of one solve from its warm start in v: sweep(rows, count, change2,
  // size2, failures) updates the listed rows once each, residual(rows, count, f2, scale2) adds
  // their natural-map terms; NNCG on momentum_impulses where settings take it.
  using RowSweep = std::function<void(const int* rows, int count, double& change2, double& size2,
                                      int& failures)>;
  using RowResidual = std::function<void(const int* rows, int count, double& f2, double& scale2)>;
  SolverStats sweepInRankOrder(const SolverSettings& settings,
                               std::initializer_list<ImpulseArray> momentum_impulses, VectorX& v,
                               const RowSweep& sweep, const RowResidual& residual);
  // scheme B: both stages in rank order (solveCatchingUp's bookkeeping, these stage solves)
  void solveCatchingUpInRankOrder();
  SolverStats frictionStageInRankOrder(const std::vector<double>* threshold_impulse, VectorX& v);
  // stage 5b's projection on the closed normals across the ranks (workspace offsets); returns
  // the row visits
  long projectAcrossRanks(const FrictionRowRule& rule);
  // z on each body the rows of several ranks touch: the sum of those ranks' parts, in rank order
  void sumSharedParts(VectorX& z);
  bool anyOverRanks(bool mine);
  // element by element over the ranks, in rank order: the same bits on every rank
  void sumOverRanks(std::vector<double>& values);
  void recordSolve(std::chrono::steady_clock::time_point start, const SolverStats& solve);
  void solveInRankOrder();
  // the velocities of the shared bodies this rank's rows touch, to their other holders
  // (sender), or theirs received (every rank calls it: an all-to-all)
  void sendSharedVelocities(bool sender, VectorX& v);
  double divisor(int body) const {
    return settings_.interface == RankInterface::SplitMasses ? multiplicity_[body] : 1.0;
  }
  void reduceStats();
  // this rank's verdict on the step: a body that ran away, or an owned grain whose state is no
  // longer finite (failure_ empty: neither)
  // stages 2 to 5 of the step (detection with margins of at least `at_least`, the ghost width
  // checked, free velocity, assembly, the solve over the ranks)
  void detectAndSolve(const DetectionMargins& at_least);
  // the whole scene's margin speeds (StepData::scene_speeds): the ranks' owned grains combined
  MarginSpeeds sceneSpeeds();
  void findFailure();
  void ownedEnergies(double& kinetic, double& potential) const;
  void writeState(const ParticleSet& set, int i);
  // after the ghosts arrive: the last step's contacts whose owner changed go to their new owner
  // with their impulses and frames, into its previous list (sorted by key as detection needs)
  void handOverContacts();
  // a grain's centre at q: its body's origin (the grain is centred on it)
  Vector3 centre(const Body& body, const VectorX& q) const;

  RankGroup ranks_;
  DistributedSettings settings_;
  StepModel m_;
  StepData d_;
  std::optional<DomainDecomposition> decomposition_;  // from reset on
  int nq_ = 0, nv_ = 0;                               // of each particle's floating joint
  std::vector<int> particle_body_;                    // the bodies with dofs (every one a particle)
  std::vector<char> is_particle_;                     // per body
  std::vector<int> component_of_;                     // per particle body: its tree
  std::string failure_;                               // this step's, on this rank
  bool runaway_ = false;
  ParticleSet owned_, ghosts_;
  std::vector<char> local_;             // per body: owned or ghost on this rank
  std::vector<char> counted_;           // per body: owned here (sceneSpeeds)
  std::vector<double> speed_bounds_;    // sceneSpeeds' all-reduce
  std::vector<std::int64_t> admitted_;  // a screening round's admitted candidates, summed
  std::vector<int> owner_;              // per local body: its owner
  std::vector<int> local_bodies_;       // owned, then ghosts, each once
  double largest_diameter_ = 0.0;
  // the ghost band: its width from the settings, and the last detection's reach (the largest
  // diameter plus the margin), which the next step's band covers with kGhostSlack to spare
  static constexpr double kGhostSlack = 1.1;
  double base_ghost_width_ = 0.0, reach_ = 0.0;
  // shared bodies: touch_out_[r] the bodies owned by r that this rank's contacts touch (in the
  // order sent), touch_in_[r] this rank's bodies that r's contacts touch
  std::vector<std::vector<int>> touch_out_, touch_in_;
  std::vector<char> touched_;         // per body: by this rank's contacts
  std::vector<char> moved_;           // per glued body: by this rank's rows (ordered sweeps)
  std::vector<int> touched_list_;     // the bodies marked in touched_
  std::vector<double> multiplicity_;  // per body: ranks whose contacts touch it
  std::vector<int> glued_;            // bodies this rank glues or is glued for, each once
  std::vector<int> glued_index_;      // per body: its place in glued_, or -1
  // per glued body, nv_ each: this rank's push c = v_end - v_in, the glued velocity, and the
  // velocity the next sweeps start from
  std::vector<double> push_, glued_velocity_, v_in_;
  std::vector<int> warm_order_;  // 0 .. rows - 1: the warm start's order
  // per glued body g, the ranks whose contacts touch it: toucher_rank_[toucher_begin_[g] ..
  // toucher_begin_[g + 1])
  std::vector<int> toucher_begin_, toucher_rank_;
  std::vector<std::vector<int>> touchers_scratch_;
  std::int64_t shared_count_ = 0;  // glued bodies this rank touches that another rank does
  int colours_ = 1, my_colour_ = 0;
  std::vector<int> interior_rows_, interface_rows_;
  // ordered sweeps: the interior rows swept in colour c's turn, [turn_begin_[c], [c + 1])
  std::vector<int> turn_begin_;
  std::vector<double> base_inverse_mass_, base_inverse_inertia_;  // per body, unsplit
  std::vector<int> split_;                   // bodies whose masses are split this step
  std::vector<std::int64_t> contact_count_;  // per body: of the last step (the balance's work)
  std::vector<int> work_counted_;            // the bodies whose contact_count_ is not 0
  VectorX stage_base_;  // the velocity a stage's solve starts from (scheme A: v_free)
  // the projection's conjugate gradients: rows, scaled unknowns, residuals, directions, and
  // the velocities of the direction and of the iterate
  std::vector<int> cg_rows_;
  std::vector<double> cg_scale_, cg_carried2_, cg_x_, cg_r_, cg_p_, cg_Ap_, shared_sum_;
  VectorX cg_velocity_p_, cg_velocity_x_;
  std::vector<std::vector<double>> send_, receive_;
  // handOverContacts' merge: the order by key, and the lists in that order
  std::vector<int> merge_order_;
  std::vector<Contact> merged_contacts_;
  std::vector<Vector3> merged_impulse_;
  std::vector<Vector2> merged_rolling_;
  std::vector<StagedImpulse> merged_staged_;
  std::int64_t handed_over_ = 0, carried_ = 0;    // this rank's, this step
  std::vector<double> reduce_mine_, reduce_all_;  // the solve's sums, gathered every sweep
  DistributedStats dstats_;
  std::int64_t bytes_ = 0;  // sent by this rank in this step
  bool balance_now_ = true;
  long steps_ = 0;
};

}  // namespace sweep
