// The step's solve (step 5 of both schemes, time_stepper.hpp): candidate screening, scheme A's
// coupled solve, scheme B's two stages, and the impulses kept as the next step's warm start.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>

#include "framework/dynamics.hpp"
#include "framework/parallel.hpp"
#include "integrators/screening.hpp"
#include "integrators/time_stepper.hpp"

namespace sweep {

namespace stepping {

void shiftForAdhesion(const StepModel& m, StepData& d) {
  d.adhesion_impulse.clear();
  if (!m.cmodel.adhesive()) return;
  const int n = d.problem.size();
  d.adhesion_impulse.assign(n, 0.0);
  for (int c = 0; c < n; ++c) {
    const int id = d.problem.contact[c];
    if (id < 0) continue;  // joint limits and constraints
    const double impulse = m.settings.h * adhesionForce(m.cmodel, d.contact_data.contacts[id]);
    if (impulse == 0.0) continue;
    d.adhesion_impulse[c] = impulse;
    d.P[c].x() += impulse;
  }
}

void applyAdhesionImpulses(const StepData& d, VectorX& v) {
  for (std::size_t c = 0; c < d.adhesion_impulse.size(); ++c)
    if (d.adhesion_impulse[c] != 0.0)
      d.problem.applyImpulse(static_cast<int>(c), Vector3(-d.adhesion_impulse[c], 0.0, 0.0), v);
}

void unshiftAdhesion(StepData& d) {
  for (std::size_t c = 0; c < d.adhesion_impulse.size(); ++c) d.P[c].x() -= d.adhesion_impulse[c];
}

void solve(const StepModel& m, StepData& d) {
  solveScreened(
      m, d,
      [&] {
        m.settings.scheme == Scheme::MoreauJean ? solveMoreauJean(m, d) : solveCatchingUp(m, d);
      },
      [](int admitted) { return admitted; }, false);
}

void solveScreened(const StepModel& m, StepData& d, const std::function<void()>& solve_once,
                   const std::function<int(int)>& agree, bool adhesion_in_solve) {
  d.stats.solves = 1;
  d.stats.deferred = d.stats.unassembled = 0;
  // once a step: screening never defers an adhesive row
  shiftForAdhesion(m, d);
  if (!adhesion_in_solve) applyAdhesionImpulses(d, d.v_free);
  if (!m.settings.screening) {
    solve_once();
    keepImpulses(m, d);
    unshiftAdhesion(d);
    return;
  }
  d.v_contact_free = d.v_free;
  int iterations1 = 0, iterations2 = 0;
  long updates = 0;
  double t_solve = 0.0;
  for (;;) {
    solve_once();
    keepImpulses(m, d);
    iterations1 += d.stats.iterations_stage1;
    iterations2 += d.stats.iterations_stage2;
    updates += d.stats.updates;
    t_solve += d.stats.t_solve;
    if (agree(admitViolators(m, d)) == 0) break;
    if (++d.stats.solves > m.settings.screening_rounds) {  // the last round: every candidate
      std::fill(d.deferred.begin(), d.deferred.end(), 0);
      std::fill(d.unassembled.begin(), d.unassembled.end(), 0);
      d.jacobian_stale = true;
    }
    d.v_free = d.v_contact_free;
    if (d.jacobian_stale) assembleJacobian(m, d);
    assembleProblem(m, d);
    shiftForAdhesion(m, d);
  }
  unshiftAdhesion(d);
  d.contact_dv = d.v_free - d.v_contact_free;
  d.stats.iterations_stage1 = iterations1;
  d.stats.iterations_stage2 = iterations2;
  d.stats.updates = updates;
  d.stats.t_solve = t_solve;
  d.stats.deferred = static_cast<int>(std::count(d.deferred.begin(), d.deferred.end(), 1));
  d.stats.unassembled = static_cast<int>(std::count(d.unassembled.begin(), d.unassembled.end(), 1));
}

int admitViolators(const StepModel& m, StepData& d) {
  const ContactJacobian& J = d.contact_data.jacobian;
  // round-off only: a contact let through would differ from the unscreened solve
  const double tau = 0.5 * m.settings.h, slack = touchingGap(m.cmodel);
  const double t_m = d.t + 0.5 * m.settings.h;
  const int threads = m.threads;
  rootBodyTwists(m.model, d.model_data, d.v_free, d.end_twist, threads);
  int admitted = 0;
  bool stale = false;
  const int contacts = static_cast<int>(d.deferred.size());
  auto judge = [&](int id, int& admitted_part, bool& stale_part) {
    if (!d.deferred[id]) return;
    if (d.unassembled[id]) {
      std::array<double, 1> u_end;
      normalVelocitiesFromTwists<1>(m.model, d.model_data, d.contact_data.contacts[id],
                                    {&d.end_twist}, t_m, u_end);
      if (tau * (u_end[0] + d.screening_bias[id]) < -slack) {
        d.deferred[id] = d.unassembled[id] = 0;
        stale_part = true;  // its rows are built before the next solve
        ++admitted_part;
      }
      return;
    }
    if (tau * (J.relativeVelocity(id, d.v_free).x() + d.screening_bias[id]) < -slack) {
      d.deferred[id] = 0;
      ++admitted_part;
    }
  };
  if (threads > 1 && contacts >= kParallelItems) {
#pragma omp parallel for schedule(static) num_threads(threads) reduction(+ : admitted) \
    reduction(|| : stale)
    for (int id = 0; id < contacts; ++id) judge(id, admitted, stale);
  } else {
    for (int id = 0; id < contacts; ++id) judge(id, admitted, stale);
  }
  if (stale) d.jacobian_stale = true;
  return admitted;
}

void keepImpulses(const StepModel& m, StepData& d) {
  // a joint limit or constraint out of this solve carries nothing (they are never deferred)
  std::fill(d.limit_impulse.begin(), d.limit_impulse.end(), 0.0);
  std::fill(d.constraint_impulse.begin(), d.constraint_impulse.end(), Vector3::Zero());
  // rows name distinct contacts, limits and constraints: each writes its own entries
  const int n = d.problem.size();
  forEachIndex(n, m.threads, [&](int c) {
    const int id = d.problem.contact[c];
    const RowOwner owner = rowOwner(m.model, id);
    if (owner.kind == RowOwner::Limit) {
      d.limit_impulse[owner.index] = d.P[c].x();
      return;
    }
    if (owner.kind == RowOwner::Constraint) {
      d.constraint_impulse[owner.index] = d.P[c];
      return;
    }
    d.impulse[id] = d.P[c];
    if (!d.adhesion_impulse.empty()) d.impulse[id].x() -= d.adhesion_impulse[c];
    if (d.problem.rolling) d.rolling[id] = d.R[c];
    d.solved[id] = 1;
  });
}

double metricKinetic(const StepModel& m, StepData& d, const VectorX& v) {
  // v_c^T M_c v_c per tree, summed in fixed chunks of trees (the same bits on any thread
  // count), without a temporary: a free body's block as a fixed-size 6 x 6
  auto quadratic = [&](int c) {
    const Component& comp = m.model.components[c];
    const MatrixX& M = d.model_data.mass_blocks[c];
    if (comp.nv == 6) {
      const auto v_c = v.segment<6>(comp.v_index);
      return v_c.dot(Eigen::Map<const Matrix6>(M.data()) * v_c);
    }
    const auto v_c = v.segment(comp.v_index, comp.nv);
    double sum = 0.0;
    for (int j = 0; j < comp.nv; ++j) sum += v_c[j] * M.col(j).dot(v_c);
    return sum;
  };
  const int trees = static_cast<int>(m.model.components.size() - m.model.systems.size());
  double twice = sumInChunks(trees, m.threads,
                             [&](long c, double& sum) { sum += quadratic(static_cast<int>(c)); });
  for (int c = trees; c < static_cast<int>(m.model.components.size()); ++c) twice += quadratic(c);
  return 0.5 * twice;
}

void solveMoreauJean(const StepModel& m, StepData& d) {
  const auto start = std::chrono::steady_clock::now();
  VectorX& v = d.v_free;  // becomes d.v{k+1}
  d.stats.kinetic_free = metricKinetic(m, d, v);
  const SolverStats s = solveCoulombNlgs(d.problem, m.settings.coulomb, d.P, v, d.solver_ws,
                                         d.problem.rolling ? &d.R : nullptr);
  d.stats.iterations_stage1 = s.iterations;
  d.stats.iterations_stage2 = 0;
  d.stats.updates = s.updates;
  d.stats.residual = s.residual;
  d.stats.status = s.status;
  // a solve that used every sweep is a cap hit even when its residual passes at the end
  // (velocities converged, impulses still moving among redundant rows): users count these
  d.stats.cap_hit =
      s.iterations >= m.settings.coulomb.max_iterations || s.status == SolverStatus::MaxIterations;
  d.stats.local_failures = s.local_failures;
  d.stats.kinetic_stage1 = d.stats.kinetic_solved = metricKinetic(m, d, v);
  d.stats.t_solve = secondsSince(start);
}

namespace {
// warm-start value of problem row c: a model row's own, or its contact's previous impulse
const StagedImpulse* previousStaged(const StepData& d, int c) {
  const int id = d.problem.contact[c];
  if (id < 0) return &d.limit_staged[-1 - id];  // limits, then constraints (StepData)
  if (d.solved[id]) return &d.staged[id];       // an earlier round of candidate screening
  const int previous = d.contact_data.contacts[id].previous;
  if (previous < 0 || previous >= static_cast<int>(d.previous_staged.size())) return nullptr;
  return &d.previous_staged[previous];
}
}  // namespace

void solveCatchingUp(const StepModel& m, StepData& d) {
  // each stage's lambda holds two references, which std::function keeps without allocating
  solveCatchingUp(
      m, d,
      {[&m, &d](VectorX& v) {
         return solveNormalStage(d.problem, m.settings.normal_stage, d.lambda_N, v, d.solver_ws);
       },
       [&m, &d](const std::vector<double>* threshold, VectorX& v) {
         return solveFrictionStage(d.problem, m.settings.friction_stage, m.settings.friction,
                                   d.lambda_N, d.delta, d.lambda_T, v, d.solver_ws,
                                   d.problem.rolling ? &d.R : nullptr, threshold);
       }});
}

void solveCatchingUp(const StepModel& m, StepData& d, const StageSolves& stages) {
  const auto start = std::chrono::steady_clock::now();
  const int n = d.problem.size();
  VectorX& v = d.v_free;
  // warm start each stage from its own previous values
  d.lambda_N.assign(n, 0.0);
  d.delta.assign(n, 0.0);
  d.lambda_T.assign(n, Vector2::Zero());
  for (int c = 0; c < n; ++c) {
    const StagedImpulse* previous = previousStaged(d, c);
    if (previous == nullptr) continue;
    d.lambda_N[c] = previous->normal;
    d.delta[c] = previous->delta;
    d.lambda_T[c] = previous->tangent;
  }
  d.stats.kinetic_free = metricKinetic(m, d, v);
  // 5a: frictionless inelastic shock on the scaled normals
  const SolverStats normal = stages.normal(v);
  d.stats.iterations_stage1 = normal.iterations;
  d.stats.updates = normal.updates;
  d.stats.residual = normal.residual;
  d.stats.status = normal.status;
  d.stats.cap_hit = normal.iterations >= m.settings.normal_stage.max_iterations ||
                    normal.status == SolverStatus::MaxIterations;
  d.stats.iterations_stage2 = 0;
  d.stats.kinetic_stage1 = metricKinetic(m, d, v);
  // 5b: friction with frozen thresholds, skipped when no contact or constraint can have it
  if (!m.cmodel.frictionless || m.constraint_friction) {
    const int rounds = 1 + m.settings.friction.threshold_updates;
    if (rounds > 1) d.v_stage1 = v;
    for (int round = 0; round < rounds; ++round) {
      const std::vector<double>* threshold = nullptr;
      if (round > 0) {
        // thresholds from the last round's total normal impulse on the rows 5a closed
        d.threshold_impulse.assign(n, 0.0);
        for (int c = 0; c < n; ++c)
          if (d.lambda_N[c] > 0.0)
            d.threshold_impulse[c] =
                std::max(d.lambda_N[c] + d.delta[c] +
                             tangentNormalPart(d.problem, c, m.settings.friction, d.lambda_T[c]),
                         0.0);
        threshold = &d.threshold_impulse;
        v = d.v_stage1;
      }
      const SolverStats friction = stages.friction(threshold, v);
      d.stats.iterations_stage2 += friction.iterations;
      d.stats.updates += friction.updates;
      if (round + 1 < rounds) continue;
      // the last round's convergence is the step's
      d.stats.residual = std::max(d.stats.residual, friction.residual);
      d.stats.cap_hit = d.stats.cap_hit ||
                        friction.iterations >= m.settings.friction_stage.max_iterations ||
                        friction.status == SolverStatus::MaxIterations;
      if (friction.status != SolverStatus::Converged) d.stats.status = friction.status;
    }
  } else {
    std::fill(d.delta.begin(), d.delta.end(), 0.0);
    std::fill(d.lambda_T.begin(), d.lambda_T.end(), Vector2::Zero());
  }
  for (int c = 0; c < n; ++c) {
    const double normal_total = d.lambda_N[c] + d.delta[c] +
                                tangentNormalPart(d.problem, c, m.settings.friction, d.lambda_T[c]);
    d.P[c] = Vector3(normal_total, d.lambda_T[c].x(), d.lambda_T[c].y());
    const int id = d.problem.contact[c];
    (id < 0 ? d.limit_staged[-1 - id] : d.staged[id]) =
        StagedImpulse{d.lambda_N[c], d.delta[c], d.lambda_T[c]};
  }
  d.stats.local_failures = 0;
  d.stats.kinetic_solved = metricKinetic(m, d, v);
  d.stats.t_solve = secondsSince(start);
}

}  // namespace stepping
}  // namespace sweep
