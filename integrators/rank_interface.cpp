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

double DistributedStepper::startStage(VectorX& v, const std::function<void(VectorX&)>& warm) {
  const auto nv = static_cast<std::size_t>(nv_);
  stage_base_ = v;
  push_.assign(glued_.size() * nv, 0.0);
  glued_velocity_.assign(glued_.size() * nv, 0.0);
  v_in_.resize(glued_.size() * nv);
  for (std::size_t g = 0; g < glued_.size(); ++g)
    for (std::size_t k = 0; k < nv; ++k)
      v_in_[g * nv + k] = stage_base_[m_.model.bodies[glued_[g]].v_index + k];
  const int n = d_.problem.size();
  warm_order_.resize(static_cast<std::size_t>(n));
  for (int c = 0; c < n; ++c) warm_order_[c] = c;
  warm(v);
  double mismatch = 0.0;
  glue(stage_base_, v, mismatch);
  return mismatch;
}

double DistributedStepper::startFromWarmStart(VectorX& v) {
  return startStage(v, [&](VectorX& warm) {
    // the adhesive rows' -h F is part of this rank's push, summed on shared bodies as the rest
    stepping::applyAdhesionImpulses(d_, warm);
    warmStart(d_.problem, d_.P, d_.problem.rolling ? &d_.R : nullptr, warm_order_.data(),
              d_.problem.size(), warm);
  });
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
    glue(stage_base_, v, mismatch);
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

void DistributedStepper::splitRowsForTurns() {
  interior_rows_.clear();
  interface_rows_.clear();
  for (const int b : glued_) moved_[b] = 0;
  for (int c = 0; c < d_.problem.size(); ++c) {
    const Contact& contact = d_.contact_data.contacts[d_.problem.contact[c]];
    bool shared = false;
    for (const BodyRef* body : {&contact.body_a, &contact.body_b})
      if (body->kind == BodyRef::Kind::Dynamic && glued_index_[body->index] >= 0) {
        shared = true;
        moved_[body->index] = 1;
      }
    (shared ? interface_rows_ : interior_rows_).push_back(c);
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
}

SolverStats DistributedStepper::sweepInRankOrder(
    const SolverSettings& settings, std::initializer_list<ImpulseArray> momentum_impulses,
    VectorX& v, const RowSweep& sweep, const RowResidual& residual) {
  const int n = d_.problem.size();
  SolverStats stats;
  // NNCG as the single process takes it (integrators/sweeps.hpp), with the sweep's change
  // summed over every rank: the same momentum on every copy of a shared body
  std::optional<NncgMomentum> momentum;
  if (settings.acceleration == NlgsAcceleration::Nncg && n > 0) {
    prepareNncg(settings, d_.problem, v, d_.solver_ws);
    std::copy(warm_order_.begin(), warm_order_.end(), d_.solver_ws.order.begin());
    momentum.emplace(d_.problem, momentum_impulses, v, d_.solver_ws, n);
  }
  const int interface = static_cast<int>(interface_rows_.size());
  bool converged = false;
  for (int it = 0; it < settings.max_iterations; ++it) {
    double change2 = 0.0, size2 = 0.0;
    stats.local_failures = 0;
    for (int colour = 0; colour < colours_; ++colour) {
      sweep(interior_rows_.data() + turn_begin_[colour],
            turn_begin_[colour + 1] - turn_begin_[colour], change2, size2, stats.local_failures);
      const bool mine = colour == my_colour_;
      if (mine) sweep(interface_rows_.data(), interface, change2, size2, stats.local_failures);
      sendSharedVelocities(mine, v);
    }
    ++stats.iterations;
    stats.updates += n;
    // the sums over every rank, in rank order: one verdict on every rank
    reduce_mine_.assign({change2, size2});
    sumOverRanks(reduce_mine_);
    const double change_all = reduce_mine_[0], size_all = reduce_mine_[1];
    if (residualDue(settings, it, change_all, size_all)) {
      reduce_mine_.assign({0.0, 0.0});
      residual(warm_order_.data(), n, reduce_mine_[0], reduce_mine_[1]);
      sumOverRanks(reduce_mine_);
      stats.residual = relative(reduce_mine_[0], reduce_mine_[1]);
      if (!std::isfinite(stats.residual)) break;
      if (momentum) momentum->watch(stats.residual);
      if (stats.residual < settings.tolerance) {
        converged = true;
        break;
      }
    }
    if (momentum && it + 1 < settings.max_iterations) momentum->step(change_all, v);
  }
  stats.status = converged ? SolverStatus::Converged : SolverStatus::MaxIterations;
  return stats;
}

void DistributedStepper::solveInRankOrder() {
  const auto start = Clock::now();
  VectorX& v = d_.v_free;  // becomes v_{k+1}
  const SolverSettings& settings = m_.settings.coulomb;
  std::vector<Vector2>* R = d_.problem.rolling ? &d_.R : nullptr;
  splitRowsForTurns();
  startFromWarmStart(v);
  const SolverStats solve = sweepInRankOrder(
      settings, {impulses(d_.P), impulses(R)}, v,
      [&](const int* rows, int count, double& change2, double& size2, int& failures) {
        sweepCoulombRows(d_.problem, settings, d_.P, R, v, rows, count, change2, size2, failures);
      },
      [&](const int* rows, int count, double& f2, double& scale2) {
        coulombResidualSums(d_.problem, d_.P, R, v, rows, count, f2, scale2);
      });
  recordSolve(start, solve);
  dstats_.exchanges = solve.iterations * colours_;
  dstats_.mismatch = 0.0;
}

namespace {
// the stage solvers' settings on ranks: NLGS (`auto`: with NNCG, as on grains in one process)
SolverSettings onRanks(const SolverSettings& given) {
  SolverSettings settings = given;
  if (settings.solver == StageSolver::Auto) settings.acceleration = NlgsAcceleration::Nncg;
  settings.solver = StageSolver::Nlgs;
  return settings;
}
}  // namespace

bool DistributedStepper::anyOverRanks(bool mine) {
  admitted_.assign(1, mine ? 1 : 0);
  ranks_.sum(admitted_);
  return admitted_[0] > 0;
}

void DistributedStepper::solveCatchingUpInRankOrder() {
  splitRowsForTurns();
  const ContactProblem& p = d_.problem;
  const SolverSettings normal_settings = onRanks(m_.settings.normal_stage);
  auto normalStage = [&](VectorX& v) {
    std::vector<double>& lambda_N = d_.lambda_N;
    startStage(v, [&](VectorX& warm) {
      // the adhesive rows' -h F is part of this rank's push, summed on shared bodies as the rest
      stepping::applyAdhesionImpulses(d_, warm);
      for (int c = 0; c < p.size(); ++c) p.applyImpulse(c, Vector3(lambda_N[c], 0.0, 0.0), warm);
    });
    const RowReader rows(p, RowReader::kPacked2d | RowReader::kPacked3d | RowReader::kSpheres3d);
    const double omega = normal_settings.relaxation;
    return sweepInRankOrder(
        normal_settings, {impulses(lambda_N)}, v,
        [&](const int* list, int count, double& change2, double& size2, int&) {
          rows.forEach(list, 0, count, [&](int k, const auto& row) {
            normalUpdate(row, omega, lambda_N[list[k]], v, change2, size2);
          });
        },
        [&](const int* list, int count, double& f2, double& scale2) {
          rows.forEach(list, 0, count, [&](int k, const auto& row) {
            normalResidualTerms(row, lambda_N[list[k]], v, f2, scale2);
          });
        });
  };
  stepping::solveCatchingUp(
      m_, d_, {normalStage, [&](const std::vector<double>* threshold_impulse, VectorX& v) {
                 return frictionStageInRankOrder(threshold_impulse, v);
               }});
}

SolverStats DistributedStepper::frictionStageInRankOrder(
    const std::vector<double>* threshold_impulse, VectorX& v) {
  // solveFrictionStageNlgs (friction_stage.cpp) with its sweeps, its projection and the
  // decision whether any row has friction taken over every rank
  const ContactProblem& p = d_.problem;
  const SolverSettings settings = onRanks(m_.settings.friction_stage);
  const FrictionStageOptions& options = m_.settings.friction;
  SolverWorkspace& ws = d_.solver_ws;
  std::vector<Vector2>* R = p.rolling ? &d_.R : nullptr;
  prepareFrictionStage(p, options, d_.lambda_N, threshold_impulse, v, ws);
  const FrictionRowRule rule{p, options, d_.lambda_N};
  bool mine = false;
  for (int c = 0; c < p.size(); ++c)
    mine = mine || ws.threshold[c] > 0.0 || (hasRollingRow(p, R, c) && d_.lambda_N[c] > 0.0);
  const bool any = anyOverRanks(mine);
  SolverStats total;
  std::fill(ws.offset.begin(), ws.offset.end(), Vector2::Zero());
  if (anyOverRanks(any && rule.needsProjection())) total.updates += projectAcrossRanks(rule);
  const FrictionStageRows stage{
      p, options, rule, ws, d_.lambda_N, d_.delta, d_.lambda_T, R, settings.relaxation};
  startStage(v, [&](VectorX& warm) { warmStartFriction(stage, any, warm); });
  if (!any) return total;
  const bool rolling_fits = R == nullptr || static_cast<int>(R->size()) == p.size();
  const RowReader rows(
      p, RowReader::kPacked2d | (rolling_fits ? RowReader::kPacked3d | RowReader::kSpheres3d : 0u));
  SolverStats sweeps = sweepInRankOrder(
      settings, {impulses(&d_.lambda_T), impulses(d_.delta), impulses(R)}, v,
      [&](const int* list, int count, double& change2, double& size2, int&) {
        rows.forEach(list, 0, count, [&](int k, const auto& row) {
          stage.update(row, list[k], v, change2, size2);
        });
      },
      [&](const int* list, int count, double& f2, double& scale2) {
        rows.forEach(list, 0, count, [&](int k, const auto& row) {
          stage.residualTerms(row, list[k], v, f2, scale2);
        });
      });
  sweeps.updates += total.updates;
  return sweeps;
}

void DistributedStepper::sumSharedParts(VectorX& z) {
  const int size = ranks_.size(), rank = ranks_.rank();
  const auto nv = static_cast<std::size_t>(nv_);
  auto sharedHere = [&](std::size_t g) {
    return touched_[glued_[g]] && toucher_begin_[g + 1] - toucher_begin_[g] > 1;
  };
  for (int r = 0; r < size; ++r) send_[r].clear();
  std::int64_t doubles = 0;
  for (std::size_t g = 0; g < glued_.size(); ++g) {
    if (!sharedHere(g)) continue;
    const int b = glued_[g];
    const int first = m_.model.bodies[b].v_index;
    for (int t = toucher_begin_[g]; t < toucher_begin_[g + 1]; ++t) {
      const int r = toucher_rank_[t];
      if (r == rank) continue;
      send_[r].push_back(b);
      for (std::size_t k = 0; k < nv; ++k) send_[r].push_back(z[first + k]);
      doubles += static_cast<std::int64_t>(1 + nv);
    }
  }
  bytes_ += 8 * doubles;
  ranks_.exchange(send_, receive_);
  // every holder adds the same parts in the same (rank) order: the same bits on each
  shared_sum_.assign(glued_.size() * nv, 0.0);
  for (int r = 0; r < size; ++r) {
    if (r == rank) {
      for (std::size_t g = 0; g < glued_.size(); ++g) {
        if (!sharedHere(g)) continue;
        const int first = m_.model.bodies[glued_[g]].v_index;
        for (std::size_t k = 0; k < nv; ++k) shared_sum_[g * nv + k] += z[first + k];
      }
      continue;
    }
    for (std::size_t at = 0; at + 1 + nv <= receive_[r].size(); at += 1 + nv) {
      const auto g = static_cast<std::size_t>(glued_index_[static_cast<int>(receive_[r][at])]);
      for (std::size_t k = 0; k < nv; ++k) shared_sum_[g * nv + k] += receive_[r][at + 1 + k];
    }
  }
  for (std::size_t g = 0; g < glued_.size(); ++g) {
    if (!sharedHere(g)) continue;
    const int first = m_.model.bodies[glued_[g]].v_index;
    for (std::size_t k = 0; k < nv; ++k) z[first + k] = shared_sum_[g * nv + k];
  }
}

long DistributedStepper::projectAcrossRanks(const FrictionRowRule& rule) {
  // projectOnClosedNormalsByCg's program, (N_A^T M^-1 N_A) y = N_A^T v1 on each closed row's
  // unknown scaled by s_N = sqrt(W_NN), by conjugate gradients from y = 0, stopped on its
  // residual (each row's measured against the normal impulse the row carries)
  const ContactProblem& p = d_.problem;
  SolverWorkspace& ws = d_.solver_ws;
  const SolverSettings& settings = m_.settings.friction_stage;
  cg_rows_.clear();
  cg_scale_.clear();
  cg_carried2_.clear();
  cg_r_.clear();
  for (int c = 0; c < p.size(); ++c) {
    const double s_N = std::sqrt(p.delassus[c](0, 0));
    if (!rule.closed(c) || !(s_N > 0.0 && std::isfinite(s_N))) continue;
    cg_rows_.push_back(c);
    cg_scale_.push_back(1.0 / s_N);
    const double carried = s_N * rule.lambda_N[c];
    cg_carried2_.push_back(carried * carried);
    cg_r_.push_back((ws.held_normal[c] - p.known[c].x()) / s_N);  // b - A y at y = 0
  }
  const std::size_t rows = cg_rows_.size();
  cg_x_.assign(rows, 0.0);
  cg_p_ = cg_r_;
  cg_Ap_.assign(rows, 0.0);
  const auto size = static_cast<Eigen::Index>(d_.v_free.size());
  if (cg_velocity_p_.size() != size) cg_velocity_p_.setZero(size);
  if (cg_velocity_x_.size() != size) cg_velocity_x_.setZero(size);
  auto clear = [&](VectorX& z) {
    for (const int b : touched_list_) z.segment(m_.model.bodies[b].v_index, nv_).setZero();
  };
  clear(cg_velocity_x_);
  long products = 0;
  double rr_previous = 0.0;
  for (int it = 0;; ++it) {
    // the residual as MPRGP measures a free block's, and |r|^2, summed over the ranks
    reduce_mine_.assign({0.0, 0.0});
    for (std::size_t i = 0; i < rows; ++i) {
      const double r2 = cg_r_[i] * cg_r_[i];
      reduce_mine_[0] += r2;
      reduce_mine_[1] += std::max(cg_x_[i] * cg_x_[i], r2) + cg_carried2_[i];
    }
    sumOverRanks(reduce_mine_);
    const double rr = reduce_mine_[0];
    if (relative(rr, reduce_mine_[1]) < settings.tolerance && (it > 0 || rr == 0.0)) break;
    if (it == settings.max_iterations || !std::isfinite(rr)) break;
    if (it > 0) {  // the next direction (the first is the residual)
      const double beta = rr / rr_previous;
      for (std::size_t i = 0; i < rows; ++i) cg_p_[i] = cg_r_[i] + beta * cg_p_[i];
    }
    rr_previous = rr;
    // A p: the rows' impulses on the bodies, the shared bodies' parts summed, the rows' speeds
    clear(cg_velocity_p_);
    for (std::size_t i = 0; i < rows; ++i)
      if (cg_p_[i] != 0.0)
        p.applyImpulse(cg_rows_[i], Vector3(cg_p_[i] * cg_scale_[i], 0.0, 0.0), cg_velocity_p_);
    sumSharedParts(cg_velocity_p_);
    ++products;
    reduce_mine_.assign({0.0});
    for (std::size_t i = 0; i < rows; ++i) {
      const int c = cg_rows_[i];
      cg_Ap_[i] = cg_scale_[i] * (p.localVelocity(c, cg_velocity_p_).x() - p.known[c].x());
      reduce_mine_[0] += cg_p_[i] * cg_Ap_[i];
    }
    sumOverRanks(reduce_mine_);
    const double pAp = reduce_mine_[0];
    if (!(pAp > 0.0)) break;
    const double alpha = rr / pAp;
    for (std::size_t i = 0; i < rows; ++i) {
      cg_x_[i] += alpha * cg_p_[i];
      cg_r_[i] -= alpha * cg_Ap_[i];
    }
    for (const int b : touched_list_) {
      const int first = m_.model.bodies[b].v_index;
      cg_velocity_x_.segment(first, nv_) += alpha * cg_velocity_p_.segment(first, nv_);
    }
  }
  // each row's offset W_T^T v_N: the tangential velocities of the projection
  for (int c = 0; c < p.size(); ++c) {
    const Vector3 u = p.localVelocity(c, cg_velocity_x_) - p.known[c];
    ws.offset[c] = Vector2(u.y(), u.z());
  }
  return products * p.size();
}

}  // namespace sweep
