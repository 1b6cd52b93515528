#pragma once
// Scheme A (Jean-Moreau, time_stepper.hpp) over MPI ranks: each rank steps the particles it
// owns (contact/domain_decomposition.hpp) and solves the contacts whose first body it owns;
// the bodies shared by the contacts of several ranks are glued by the nonsmooth contact
// domain decomposition (NSCDD) of Visseq, Martin, Iceta, Azema, Dureisseix & Alart,
// "Distributed nonsmooth contact domain decomposition (NSCDD): algorithmic structure and
// scalability" (Domain Decomposition Methods in Science and Engineering XXI, 2014), after
// Barboteu, Alart & Dureisseix (2001):
//
//   a body b touched by the contacts of n_b ranks takes mass m_b / n_b on each of them. Rank
//   s sweeps its contacts (NLGS) from v_in,s = v_b - c_b,s, where c_b,s = n_b M_b^-1 H_s^T P_s
//   is its own contacts' push on b, and the owner of b glues the copies after every
//   `sweeps_per_exchange` sweeps:
//     v_b = v_free,b + (1 / n_b) sum_s c_b,s = v_free,b + M_b^-1 sum_s H_s^T P_s,
//   the velocity of the whole body under every rank's impulses.
// The solve stops on the single process's test: the relative natural-map residual of every
// rank's rows at the glued velocities, summed over the ranks, below the solver's tolerance.
// The warm start (the last step's impulses) is applied and glued before the first sweeps, and
// the solver resumes from the glued velocities without applying it again (solveCoulombNlgs,
// velocity_holds_warm_start). One rank runs the plain step.
//
// Each step: the owners move with their particles (migration; rebalanced by work every
// rebalance_interval steps), the copies within ghost_width of a rank's region arrive with q
// and v (ghost exchange), and detection bins the owned and ghost grains only. Every rank holds
// the whole Model and state vectors; what it does not own or see is at rest and stale.
//
// Scope: 3D scenes whose bodies with dofs are all free spheres (walls, plates, blades and
// other driven or fixed shapes are held by every rank), scheme A, no candidate screening, no
// position projection, no adhesion, no actuators, and no re-detection on the end velocities
// (the VEL law, or detection.verify_margin off); the constructor says which field is not
// supported.
#include <cstdint>
#include <optional>
#include <vector>

#include "contact/domain_decomposition.hpp"
#include "integrators/step_data.hpp"

namespace sweep {

struct DistributedSettings {
  // NLGS sweeps between two glues of the shared bodies: 5 is the fastest of 2, 5 and 10 on the
  // powder heap (docs/benchmarks.md, "Scheme A over ranks")
  int sweeps_per_exchange = 5;
  int rebalance_interval = 0;  // steps between two rebalances by work; 0: at reset only
  // the largest centre distance of two grains that may touch within a step (m); 0: twice the
  // largest diameter. A step whose detection margin does not fit in it throws on every rank.
  double ghost_width = 0.0;
};

// What the last step moved between ranks and how its solve went, summed over the ranks.
struct DistributedStats {
  std::int64_t bytes_sent = 0;     // migration, ghosts and glue messages
  std::int64_t shared_bodies = 0;  // bodies touched by the contacts of more than one rank
  int exchanges = 0;               // glues of the shared bodies
  // largest |v copy - v glued| of the last glue (m/s; a spin difference times the largest
  // radius)
  double mismatch = 0.0;
  double imbalance = 1.0;  // the most owned grains on one rank over the mean
};

class DistributedStepper {
 public:
  // Collective. InputError naming the field for a scene or setting outside the scope above.
  DistributedStepper(const RankGroup& ranks, const Model& model, const ContactModel& cmodel,
                     const SchemeSettings& settings, const DistributedSettings& distributed = {});

  // Collective; every rank passes the same whole state.
  void reset(double t, const VectorX& q, const VectorX& v);
  // Collective. The stats are this rank's, with active, iterations, cap_hit, status, residual
  // and kinetic taken over every rank.
  const StepStats& step();
  // Collective: the whole state, each body as its owner holds it, on every rank.
  void gatherState(VectorX& q, VectorX& v) const;

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
  void reduceStats();
  void writeState(const ParticleSet& set, int i);

  RankGroup ranks_;
  DistributedSettings settings_;
  StepModel m_;
  StepData d_;
  std::optional<DomainDecomposition> decomposition_;  // from reset on
  int nq_ = 0, nv_ = 0;                               // of each particle's floating joint
  std::vector<int> particle_body_;                    // the bodies with dofs (every one a particle)
  ParticleSet owned_, ghosts_;
  std::vector<char> local_;        // per body: owned or ghost on this rank
  std::vector<int> owner_;         // per local body: its owner
  std::vector<int> local_bodies_;  // owned, then ghosts, each once
  double largest_diameter_ = 0.0;
  // shared bodies: touch_out_[r] the bodies owned by r that this rank's contacts touch (in the
  // order sent), touch_in_[r] this rank's bodies that r's contacts touch
  std::vector<std::vector<int>> touch_out_, touch_in_;
  std::vector<char> touched_;         // per body: by this rank's contacts
  std::vector<int> touched_list_;     // the bodies marked in touched_
  std::vector<double> multiplicity_;  // per body: ranks whose contacts touch it
  std::vector<int> glued_;            // bodies this rank glues or is glued for, each once
  std::vector<int> glued_index_;      // per body: its place in glued_, or -1
  // per glued body, nv_ each: this rank's push c = v_end - v_in, the glued velocity, and the
  // velocity the next sweeps start from
  std::vector<double> push_, glued_velocity_, v_in_;
  std::vector<int> warm_order_;  // 0 .. rows - 1: the warm start's order
  std::vector<double> base_inverse_mass_, base_inverse_inertia_;  // per body, unsplit
  std::vector<int> split_;                   // bodies whose masses are split this step
  std::vector<std::int64_t> contact_count_;  // per body: of the last step (the balance's work)
  VectorX v_free_;                           // the contact-free velocity of this step
  std::vector<std::vector<double>> send_, receive_;
  DistributedStats dstats_;
  std::int64_t bytes_ = 0;  // sent by this rank in this step
  bool balance_now_ = true;
  long steps_ = 0;
};

}  // namespace sweep
