// The step's solve (step 5 of both schemes, time_stepper.hpp): candidate screening, scheme A's
// coupled solve, scheme B's two stages, and the impulses kept as the next step's warm start.
#include <algorithm>
#include <chrono>
#include <cmath>

#include "framework/dynamics.hpp"
#include "framework/parallel.hpp"
#include "integrators/screening.hpp"
#include "integrators/time_stepper.hpp"

namespace sweep {

namespace {
using Clock = std::chrono::steady_clock;
double seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}
}  // namespace

void TimeStepper::solve() {
  stats_.solves = 1;
  stats_.deferred = stats_.unassembled = 0;
  if (!settings_.screening) {
    settings_.scheme == Scheme::MoreauJean ? solveMoreauJean() : solveCatchingUp();
    keepImpulses();
    return;
  }
  v_contact_free_ = v_free_;
  int iterations1 = 0, iterations2 = 0;
  long updates = 0;
  double t_solve = 0.0;
  for (;;) {
    settings_.scheme == Scheme::MoreauJean ? solveMoreauJean() : solveCatchingUp();
    keepImpulses();
    iterations1 += stats_.iterations_stage1;
    iterations2 += stats_.iterations_stage2;
    updates += stats_.updates;
    t_solve += stats_.t_solve;
    const int admitted = admitViolators();
    if (admitted == 0) break;
    if (++stats_.solves > settings_.screening_rounds) {  // the last round: every candidate
      std::fill(deferred_.begin(), deferred_.end(), 0);
      std::fill(unassembled_.begin(), unassembled_.end(), 0);
      jacobian_stale_ = true;
    }
    v_free_ = v_contact_free_;
    if (jacobian_stale_) assembleJacobian();
    assembleProblem();
  }
  contact_dv_ = v_free_ - v_contact_free_;
  stats_.iterations_stage1 = iterations1;
  stats_.iterations_stage2 = iterations2;
  stats_.updates = updates;
  stats_.t_solve = t_solve;
  stats_.deferred = static_cast<int>(std::count(deferred_.begin(), deferred_.end(), 1));
  stats_.unassembled = static_cast<int>(std::count(unassembled_.begin(), unassembled_.end(), 1));
}

int TimeStepper::admitViolators() {
  const ContactJacobian& J = cdata_.jacobian;
  // round-off only: a contact let through would differ from the unscreened solve
  const double tau = 0.5 * settings_.h, slack = touchingGap(cmodel_);
  const double t_m = t_ + 0.5 * settings_.h;
  const int threads = settings_.threadCount();
  rootBodyTwists(model_, data_, v_free_, end_twist_, threads);
  int admitted = 0;
  bool stale = false;
  const int m = static_cast<int>(deferred_.size());
#pragma omp parallel for schedule(static) num_threads(threads) if (m >= kParallelItems) \
    reduction(+ : admitted) reduction(|| : stale)
  for (int id = 0; id < m; ++id) {
    if (!deferred_[id]) continue;
    if (unassembled_[id]) {
      std::array<double, 1> u_end;
      normalVelocitiesFromTwists<1>(model_, data_, cdata_.contacts[id], {&end_twist_}, t_m, u_end);
      if (tau * (u_end[0] + screening_bias_[id]) < -slack) {
        deferred_[id] = unassembled_[id] = 0;
        stale = true;  // its rows are built before the next solve
        ++admitted;
      }
      continue;
    }
    if (tau * (J.relativeVelocity(id, v_free_).x() + screening_bias_[id]) < -slack) {
      deferred_[id] = 0;
      ++admitted;
    }
  }
  if (stale) jacobian_stale_ = true;
  return admitted;
}

void TimeStepper::keepImpulses() {
  // a joint limit or constraint out of this solve carries nothing (they are never deferred)
  std::fill(limit_impulse_.begin(), limit_impulse_.end(), 0.0);
  std::fill(constraint_impulse_.begin(), constraint_impulse_.end(), Vector3::Zero());
  // rows name distinct contacts, limits and constraints: each writes its own entries
  const int n = problem_.size();
#pragma omp parallel for schedule(static) \
    num_threads(settings_.threadCount()) if (n >= kParallelItems)
  for (int c = 0; c < n; ++c) {
    const int id = problem_.contact[c];
    if (id < 0) {
      const int m = -1 - id, limits = static_cast<int>(model_.limits.size());
      if (m < limits)
        limit_impulse_[m] = P_[c].x();
      else
        constraint_impulse_[m - limits] = P_[c];
      continue;
    }
    impulse_[id] = P_[c];
    if (problem_.rolling) rolling_[id] = R_[c];
    solved_[id] = 1;
  }
}

double TimeStepper::metricKinetic(const VectorX& v) {
  // v_c^T M_c v_c per tree, summed in fixed chunks of trees (the same bits on any thread
  // count), without a temporary: a free body's block as a fixed-size 6 x 6
  auto quadratic = [&](int c) {
    const Component& comp = model_.components[c];
    const MatrixX& M = data_.mass_blocks[c];
    if (comp.nv == 6) {
      const auto v_c = v.segment<6>(comp.v_index);
      return v_c.dot(Eigen::Map<const Matrix6>(M.data()) * v_c);
    }
    const auto v_c = v.segment(comp.v_index, comp.nv);
    double sum = 0.0;
    for (int j = 0; j < comp.nv; ++j) sum += v_c[j] * M.col(j).dot(v_c);
    return sum;
  };
  const int trees = static_cast<int>(model_.components.size() - model_.systems.size());
  double twice = sumInChunks(trees, settings_.threadCount(),
                             [&](long c, double& sum) { sum += quadratic(static_cast<int>(c)); });
  for (int c = trees; c < static_cast<int>(model_.components.size()); ++c) twice += quadratic(c);
  return 0.5 * twice;
}

void TimeStepper::solveMoreauJean() {
  const auto start = Clock::now();
  VectorX& v = v_free_;  // becomes v_{k+1}
  stats_.kinetic_free = metricKinetic(v);
  const SolverStats s = solveCoulombNlgs(problem_, settings_.coulomb, P_, v, nlgs_ws_,
                                         problem_.rolling ? &R_ : nullptr);
  stats_.iterations_stage1 = s.iterations;
  stats_.iterations_stage2 = 0;
  stats_.updates = s.updates;
  stats_.residual = s.residual;
  stats_.status = s.status;
  // a solve that used every sweep is a cap hit even when its residual passes at the end
  // (velocities converged, impulses still moving among redundant rows): users count these
  stats_.cap_hit =
      s.iterations >= settings_.coulomb.max_iterations || s.status == SolverStatus::MaxIterations;
  stats_.local_failures = s.local_failures;
  stats_.kinetic_stage1 = stats_.kinetic_solved = metricKinetic(v);
  stats_.t_solve = seconds(start);
}

const TimeStepper::StagedImpulse* TimeStepper::previousStaged(int c) const {
  const int id = problem_.contact[c];
  if (id < 0) return &limit_staged_[-1 - id];
  if (solved_[id]) return &staged_[id];  // an earlier round of candidate screening
  const int previous = cdata_.contacts[id].previous;
  if (previous < 0 || previous >= static_cast<int>(previous_staged_.size())) return nullptr;
  return &previous_staged_[previous];
}

void TimeStepper::solveCatchingUp() {
  const auto start = Clock::now();
  const int n = problem_.size();
  VectorX& v = v_free_;
  // warm start each stage from its own previous values
  lambda_N_.assign(n, 0.0);
  delta_.assign(n, 0.0);
  lambda_T_.assign(n, Vector2::Zero());
  for (int c = 0; c < n; ++c) {
    const StagedImpulse* previous = previousStaged(c);
    if (previous == nullptr) continue;
    lambda_N_[c] = previous->normal;
    delta_[c] = previous->delta;
    lambda_T_[c] = previous->tangent;
  }
  stats_.kinetic_free = metricKinetic(v);
  // 5a: frictionless inelastic shock on the scaled normals
  const SolverStats normal =
      solveNormalStage(problem_, settings_.normal_stage, lambda_N_, v, nlgs_ws_);
  stats_.iterations_stage1 = normal.iterations;
  stats_.updates = normal.updates;
  stats_.residual = normal.residual;
  stats_.status = normal.status;
  stats_.cap_hit = normal.iterations >= settings_.normal_stage.max_iterations ||
                   normal.status == SolverStatus::MaxIterations;
  stats_.iterations_stage2 = 0;
  stats_.kinetic_stage1 = metricKinetic(v);
  // 5b: friction with frozen thresholds, skipped when no contact or constraint can have it
  if (!cmodel_.frictionless || constraint_friction_) {
    const int rounds = 1 + settings_.friction.threshold_updates;
    if (rounds > 1) v_stage1_ = v;
    for (int round = 0; round < rounds; ++round) {
      const std::vector<double>* threshold = nullptr;
      if (round > 0) {
        // thresholds from the last round's total normal impulse on the rows 5a closed
        threshold_impulse_.assign(n, 0.0);
        for (int c = 0; c < n; ++c)
          if (lambda_N_[c] > 0.0)
            threshold_impulse_[c] =
                std::max(lambda_N_[c] + delta_[c] +
                             tangentNormalPart(problem_, c, settings_.friction, lambda_T_[c]),
                         0.0);
        threshold = &threshold_impulse_;
        v = v_stage1_;
      }
      const SolverStats friction = solveFrictionStage(
          problem_, settings_.friction_stage, settings_.friction, lambda_N_, delta_, lambda_T_, v,
          nlgs_ws_, problem_.rolling ? &R_ : nullptr, threshold);
      stats_.iterations_stage2 += friction.iterations;
      stats_.updates += friction.updates;
      if (round + 1 < rounds) continue;
      // the last round's convergence is the step's
      stats_.residual = std::max(stats_.residual, friction.residual);
      stats_.cap_hit = stats_.cap_hit ||
                       friction.iterations >= settings_.friction_stage.max_iterations ||
                       friction.status == SolverStatus::MaxIterations;
      if (friction.status != SolverStatus::Converged) stats_.status = friction.status;
    }
  } else {
    std::fill(delta_.begin(), delta_.end(), 0.0);
    std::fill(lambda_T_.begin(), lambda_T_.end(), Vector2::Zero());
  }
  for (int c = 0; c < n; ++c) {
    const double normal_total =
        lambda_N_[c] + delta_[c] + tangentNormalPart(problem_, c, settings_.friction, lambda_T_[c]);
    P_[c] = Vector3(normal_total, lambda_T_[c].x(), lambda_T_[c].y());
    const int id = problem_.contact[c];
    (id < 0 ? limit_staged_[-1 - id] : staged_[id]) =
        StagedImpulse{lambda_N_[c], delta_[c], lambda_T_[c]};
  }
  stats_.local_failures = 0;
  stats_.kinetic_solved = metricKinetic(v);
  stats_.t_solve = seconds(start);
}

}  // namespace sweep
