// The solve across ranks of the contacts on shared bodies (integrators/distributed_stepper.hpp,
// RankInterface): the ranks' colouring and the ordered sweeps, the split masses and their glue,
// and what both share (the warm start, the sums over ranks, the statistics).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <optional>

#include "integrators/contact_laws.hpp"
#include "integrators/distributed_stepper.hpp"
#include "integrators/nlgs.hpp"
#include "integrators/rows.hpp"
#include "integrators/sweeps.hpp"

namespace sweep {

namespace {
using Clock = std::chrono::steady_clock;
}  // namespace

void DistributedStepper::colourRanks() {
  // neighbours: the ranks whose contacts touch a body this rank's contacts touch
  const int rank = ranks_.rank();
  std::vector<double> mine;
  std::vector<char> seen(static_cast<std::size_t>(ranks_.size()), 0);
  for (std::size_t g = 0; g < glued_.size(); ++g) {
    if (!touched_[glued_[g]]) continue;
    for (int t = toucher_begin_[g]; t < toucher_begin_[g + 1]; ++t)
      if (toucher_rank_[t] != rank && !seen[toucher_rank_[t]]) {
        seen[toucher_rank_[t]] = 1;
        mine.push_back(toucher_rank_[t]);
      }
  }
  std::sort(mine.begin(), mine.end());
  mine.insert(mine.begin(), static_cast<double>(mine.size()));
  const std::vector<double> all = ranks_.gather(mine);
  // greedy colours in rank order: the same on every rank
  std::vector<int> colour(static_cast<std::size_t>(ranks_.size()), -1);
  colours_ = 0;
  std::size_t at = 0;
  for (int r = 0; r < ranks_.size(); ++r) {
    const int count = static_cast<int>(all[at++]);
    std::vector<char> used(static_cast<std::size_t>(ranks_.size()) + 1, 0);
    for (int k = 0; k < count; ++k) {
      const int neighbour = static_cast<int>(all[at++]);
      if (colour[neighbour] >= 0) used[colour[neighbour]] = 1;
    }
    int c = 0;
    while (used[c]) ++c;
    colour[r] = c;
    colours_ = std::max(colours_, c + 1);
  }
  my_colour_ = colour[rank];
}

void DistributedStepper::splitMasses(bool split) {
  auto& spheres = d_.problem_ws.sphere_particles;
  for (const int b : split_) {
    const double n = split ? multiplicity_[b] : 1.0;
    spheres[b].inverse_mass = n * base_inverse_mass_[b];
    spheres[b].inverse_inertia = n * base_inverse_inertia_[b];
  }
}

void DistributedStepper::glue(const VectorX& v_free, VectorX& v, double& mismatch) {
  const int size = ranks_.size(), rank = ranks_.rank();
  const auto nv = static_cast<std::size_t>(nv_);
  // c = v_end - v_in of each glued body this rank's contacts touch
  for (std::size_t g = 0; g < glued_.size(); ++g) {
    const int b = glued_[g];
    const int first = m_.model.bodies[b].v_index;
    for (std::size_t k = 0; k < nv; ++k)
      push_[g * nv + k] = touched_[b] ? v[first + k] - v_in_[g * nv + k] : 0.0;
  }
  std::int64_t doubles = 0;
  for (int r = 0; r < size; ++r) {
    send_[r].clear();
    for (const int b : touch_out_[r])
      for (std::size_t k = 0; k < nv; ++k)
        send_[r].push_back(push_[static_cast<std::size_t>(glued_index_[b]) * nv + k]);
    doubles += static_cast<std::int64_t>(send_[r].size());
  }
  ranks_.exchange(send_, receive_);
  // the owner sums its own push, then the other ranks' in rank order: the same bits whatever
  // the order of arrival
  for (std::size_t g = 0; g < glued_.size(); ++g) {
    const int b = glued_[g];
    if (owner_[b] != rank) continue;
    for (std::size_t k = 0; k < nv; ++k) glued_velocity_[g * nv + k] = push_[g * nv + k];
  }
  for (int r = 0; r < size; ++r)
    for (std::size_t j = 0; j < touch_in_[r].size(); ++j) {
      const auto g = static_cast<std::size_t>(glued_index_[touch_in_[r][j]]);
      for (std::size_t k = 0; k < nv; ++k) glued_velocity_[g * nv + k] += receive_[r][j * nv + k];
    }
  for (std::size_t g = 0; g < glued_.size(); ++g) {
    const int b = glued_[g];
    if (owner_[b] != rank) continue;
    const int first = m_.model.bodies[b].v_index;
    for (std::size_t k = 0; k < nv; ++k)
      glued_velocity_[g * nv + k] = v_free[first + k] + glued_velocity_[g * nv + k] / divisor(b);
  }
  for (int r = 0; r < size; ++r) {
    send_[r].clear();
    for (const int b : touch_in_[r])
      for (std::size_t k = 0; k < nv; ++k)
        send_[r].push_back(glued_velocity_[static_cast<std::size_t>(glued_index_[b]) * nv + k]);
    doubles += static_cast<std::int64_t>(send_[r].size());
  }
  ranks_.exchange(send_, receive_);
  for (int r = 0; r < size; ++r)
    for (std::size_t j = 0; j < touch_out_[r].size(); ++j) {
      const auto g = static_cast<std::size_t>(glued_index_[touch_out_[r][j]]);
      for (std::size_t k = 0; k < nv; ++k) glued_velocity_[g * nv + k] = receive_[r][j * nv + k];
    }
  bytes_ += 8 * doubles;
  // every copy takes the glued velocity; the next sweeps start from it less their own push
  mismatch = 0.0;
  for (std::size_t g = 0; g < glued_.size(); ++g) {
    const int first = m_.model.bodies[glued_[g]].v_index;
    for (std::size_t k = 0; k < nv; ++k) {
      const double glued = glued_velocity_[g * nv + k];
      // a spin difference counts as the speed it gives the surface of the largest grain
      const double lever = k < 3 ? 1.0 : 0.5 * largest_diameter_;
      if (touched_[glued_[g]])
        mismatch = std::max(mismatch, lever * std::abs(glued - v[first + k]));
      v[first + k] = glued;
      v_in_[g * nv + k] = glued - push_[g * nv + k];
    }
  }
}

double DistributedStepper::startFromWarmStart(VectorX& v) {
  const auto nv = static_cast<std::size_t>(nv_);
  v_free_ = v;
  // the adhesive rows' -h F is part of this rank's push, summed on shared bodies as the rest
  stepping::applyAdhesionImpulses(d_, v);
  push_.assign(glued_.size() * nv, 0.0);
  glued_velocity_.assign(glued_.size() * nv, 0.0);
  v_in_.resize(glued_.size() * nv);
  for (std::size_t g = 0; g < glued_.size(); ++g)
    for (std::size_t k = 0; k < nv; ++k)
      v_in_[g * nv + k] = v_free_[m_.model.bodies[glued_[g]].v_index + k];
  const int n = d_.problem.size();
  warm_order_.resize(static_cast<std::size_t>(n));
  for (int c = 0; c < n; ++c) warm_order_[c] = c;
  warmStart(d_.problem, d_.P, d_.problem.rolling ? &d_.R : nullptr, warm_order_.data(), n, v);
  double mismatch = 0.0;
  glue(v_free_, v, mismatch);
  return mismatch;
}

void DistributedStepper::sumOverRanks(std::vector<double>& values) {
  ranks_.gatherEqual(values, reduce_all_);
  const std::size_t width = values.size();
  std::fill(values.begin(), values.end(), 0.0);
  for (std::size_t r = 0; r + width <= reduce_all_.size(); r += width)
    for (std::size_t k = 0; k < width; ++k) values[k] += reduce_all_[r + k];
}

void DistributedStepper::recordSolve(Clock::time_point start, const SolverStats& solve) {
  d_.stats.iterations_stage1 = solve.iterations;
  d_.stats.iterations_stage2 = 0;
  d_.stats.updates = solve.updates;
  d_.stats.residual = solve.residual;
  d_.stats.local_failures = solve.local_failures;
  d_.stats.status = d_.v_free.allFinite() ? solve.status : SolverStatus::Failed;
  d_.stats.cap_hit = solve.status != SolverStatus::Converged;
  d_.stats.t_solve = std::chrono::duration<double>(Clock::now() - start).count();
}

void DistributedStepper::solveAcrossRanks() {
  const auto start = Clock::now();
  VectorX& v = d_.v_free;  // becomes v_{k+1}
  std::vector<std::int64_t> shared{static_cast<std::int64_t>(glued_.size())};
  ranks_.sum(shared);
  if (shared[0] == 0) {  // no body is touched by two ranks: each rank's solve is the whole
    stepping::applyAdhesionImpulses(d_, v);
    stepping::solveMoreauJean(m_, d_);
    dstats_.exchanges = 0;
    dstats_.mismatch = 0.0;
    return;
  }
  const SolverSettings& whole = m_.settings.coulomb;
  SolverSettings round = whole;
  round.max_iterations = std::min(settings_.sweeps_per_exchange, whole.max_iterations);
  int sweeps = 0, exchanges = 1, failures = 0, rounds = 0;
  long updates = 0;
  double residual = 0.0, mismatch = startFromWarmStart(v);
  bool converged = false;
  for (;;) {
    const SolverStats s = solveCoulombNlgs(d_.problem, round, d_.P, v, d_.solver_ws,
                                           d_.problem.rolling ? &d_.R : nullptr, true);
    sweeps += s.iterations;
    updates += s.updates;
    failures += s.local_failures;
    glue(v_free_, v, mismatch);
    ++exchanges;
    // The single process's test on the whole problem: the relative natural-map residual of
    // every rank's rows at the glued velocities, summed over the ranks
    reduce_mine_.assign({0.0, 0.0, s.status == SolverStatus::Failed ? 1.0 : 0.0});
    coulombResidualSums(d_.problem, d_.P, d_.problem.rolling ? &d_.R : nullptr, v,
                        warm_order_.data(), d_.problem.size(), reduce_mine_[0], reduce_mine_[1]);
    sumOverRanks(reduce_mine_);
    const double f2_all = reduce_mine_[0], scale2_all = reduce_mine_[1];
    const bool failed = reduce_mine_[2] > 0.0;
    residual = relative(f2_all, scale2_all);
    if (failed) break;
    if (residual < whole.tolerance) {
      converged = true;
      break;
    }
    // rounds, not this rank's sweeps, decide: every rank leaves the loop at the same glue
    if (++rounds * round.max_iterations >= whole.max_iterations) break;
    // the next sweeps resume from v, which glue() left at the glued velocities: every copy
    // of a glued body holds v_in + its own push, and every other body v_free + its push
  }
  recordSolve(start, {converged ? SolverStatus::Converged : SolverStatus::MaxIterations, sweeps,
                      updates, residual, failures});
  dstats_.exchanges = exchanges;
  dstats_.mismatch = mismatch;
}

void DistributedStepper::sendSharedVelocities(bool sender, VectorX& v) {
  const int size = ranks_.size(), rank = ranks_.rank();
  for (int r = 0; r < size; ++r) send_[r].clear();
  std::int64_t doubles = 0;
  if (sender) {
    for (std::size_t g = 0; g < glued_.size(); ++g) {
      const int b = glued_[g];
      // a body this rank's candidates touch but no row moves is only received: its copy
      // here misses the other ranks' NNCG momentum
      if (!moved_[b]) continue;
      const int first = m_.model.bodies[b].v_index;
      auto to = [&](int r) {
        send_[r].push_back(b);
        for (int k = 0; k < nv_; ++k) send_[r].push_back(v[first + k]);
        doubles += 1 + nv_;
      };
      bool owner_touches = false;
      for (int t = toucher_begin_[g]; t < toucher_begin_[g + 1]; ++t) {
        owner_touches = owner_touches || toucher_rank_[t] == owner_[b];
        if (toucher_rank_[t] != rank) to(toucher_rank_[t]);
      }
      if (!owner_touches && owner_[b] != rank) to(owner_[b]);
    }
  }
  bytes_ += 8 * doubles;
  ranks_.exchange(send_, receive_);
  for (int r = 0; r < size; ++r)
    for (std::size_t at = 0; at + 1 + nv_ <= receive_[r].size(); at += 1 + nv_) {
      const int first = m_.model.bodies[static_cast<int>(receive_[r][at])].v_index;
      for (int k = 0; k < nv_; ++k) v[first + k] = receive_[r][at + 1 + k];
    }
}

void DistributedStepper::solveInRankOrder() {
  const auto start = Clock::now();
  VectorX& v = d_.v_free;  // becomes v_{k+1}
  const SolverSettings& settings = m_.settings.coulomb;
  const int n = d_.problem.size();
  std::vector<Vector2>* R = d_.problem.rolling ? &d_.R : nullptr;
  interior_rows_.clear();
  interface_rows_.clear();
  for (const int b : glued_) moved_[b] = 0;
  for (int c = 0; c < n; ++c) {
    const Contact& contact = d_.contact_data.contacts[d_.problem.contact[c]];
    bool shared = false;
    for (const BodyRef* body : {&contact.body_a, &contact.body_b})
      if (body->kind == BodyRef::Kind::Dynamic && glued_index_[body->index] >= 0) {
        shared = true;
        moved_[body->index] = 1;
      }
    (shared ? interface_rows_ : interior_rows_).push_back(c);
  }
  startFromWarmStart(v);
  int sweeps = 0, failures = 0;
  long updates = 0;
  double residual = 0.0;
  bool converged = false;
  // NNCG as the single process takes it (integrators/sweeps.hpp), with the sweep's change
  // summed over every rank: the same momentum on every copy of a shared body
  std::optional<NncgMomentum> momentum;
  if (settings.acceleration == NlgsAcceleration::Nncg && n > 0) {
    prepareNncg(settings, d_.problem, v, d_.solver_ws);
    std::copy(warm_order_.begin(), warm_order_.end(), d_.solver_ws.order.begin());
    momentum.emplace(d_.problem, std::initializer_list<ImpulseArray>{impulses(d_.P), impulses(R)},
                     v, d_.solver_ws, n);
  }
  // The interior rows are spread over the colours' turns so that every rank sweeps as many
  // rows between two exchanges: with I interior and F interface rows, (I + F) / C in each of
  // the C turns, the interface rows in its own. Swept all before the first turn, a rank's
  // interior waited through the other colours' interface rows: (I + C F) a sweep, not I + F.
  const int interior = static_cast<int>(interior_rows_.size());
  const int interface = static_cast<int>(interface_rows_.size());
  const double per_turn = static_cast<double>(interior + interface) / colours_;
  turn_begin_.assign(colours_ + 1, interior);
  turn_begin_[0] = 0;
  for (int colour = 0; colour + 1 < colours_; ++colour) {
    const double share = colour == my_colour_ ? std::max(0.0, per_turn - interface) : per_turn;
    turn_begin_[colour + 1] =
        std::min(interior, turn_begin_[colour] + static_cast<int>(std::lround(share)));
  }
  for (int it = 0; it < settings.max_iterations; ++it) {
    double change2 = 0.0, size2 = 0.0;
    failures = 0;
    for (int colour = 0; colour < colours_; ++colour) {
      sweepCoulombRows(d_.problem, settings, d_.P, R, v,
                       interior_rows_.data() + turn_begin_[colour],
                       turn_begin_[colour + 1] - turn_begin_[colour], change2, size2, failures);
      const bool mine = colour == my_colour_;
      if (mine)
        sweepCoulombRows(d_.problem, settings, d_.P, R, v, interface_rows_.data(), interface,
                         change2, size2, failures);
      sendSharedVelocities(mine, v);
    }
    ++sweeps;
    updates += n;
    // the sums over every rank, in rank order: one verdict on every rank
    reduce_mine_.assign({change2, size2});
    sumOverRanks(reduce_mine_);
    const double change_all = reduce_mine_[0], size_all = reduce_mine_[1];
    if (residualDue(settings, it, change_all, size_all)) {
      reduce_mine_.assign({0.0, 0.0});
      coulombResidualSums(d_.problem, d_.P, R, v, warm_order_.data(), n, reduce_mine_[0],
                          reduce_mine_[1]);
      sumOverRanks(reduce_mine_);
      residual = relative(reduce_mine_[0], reduce_mine_[1]);
      if (!std::isfinite(residual)) break;
      if (momentum) momentum->watch(residual);
      if (residual < settings.tolerance) {
        converged = true;
        break;
      }
    }
    if (momentum && it + 1 < settings.max_iterations) momentum->step(change_all, v);
  }
  recordSolve(start, {converged ? SolverStatus::Converged : SolverStatus::MaxIterations, sweeps,
                      updates, residual, failures});
  dstats_.exchanges = sweeps * colours_;
  dstats_.mismatch = 0.0;
}

}  // namespace sweep
