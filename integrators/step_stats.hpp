#pragma once
// What a step reports (reference, section 5), and the one list of the names it is reported
// under: stats.csv's columns, the keys of Python's step dictionaries and docs/cli.md all come
// from visitStepStats.
#include <string>

#include "integrators/solver_settings.hpp"

namespace sweep {

// Per-step diagnostics (reference section 5).
struct StepStats {
  long step = 0;
  double t = 0.0;  // time at the end of the step
  int candidates = 0;
  int active = 0;             // contacts in the solve
  int iterations_stage1 = 0;  // A: the coupled solve; B: normal stage
  int iterations_stage2 = 0;  // B: friction stage (0 when skipped)
  int islands = 0;            // independent groups of contacts, solved one by one
  long updates = 0;           // local solves, all stages, islands and sweeps
  double residual = 0.0;      // largest exit residual of the stages
  bool cap_hit = false;       // a stage used all its sweeps; `status` says if it converged anyway
  SolverStatus status = SolverStatus::Converged;
  int local_failures = 0;
  double penetration_max = 0.0;  // max over contacts of max(0, -g(q_{k+1}))
  double penetration_sum = 0.0;
  int penetration_count = 0;
  // kinetic energy in the metric M(q_m) of the contact solve: of v_free, after the normal
  // stage (B; A: after the solve), and after the whole solve
  double kinetic_free = 0.0, kinetic_stage1 = 0.0, kinetic_solved = 0.0;
  double kinetic = 0.0;  // at the end of the step
  double potential = 0.0;
  double work_normal = 0.0;   // sum_c P_N (U_N(k) + U_N(k+1)) / 2
  double work_tangent = 0.0;  // sum_c P_T . (U_T(k) + U_T(k+1)) / 2
  double t_detect = 0.0, t_assemble = 0.0, t_solve = 0.0, t_update = 0.0;  // seconds
  int solves = 1;             // solves of the step: 1, or the rounds of candidate screening
  int deferred = 0;           // candidates left out of the last solve by screening
  int unassembled = 0;        // of which had no Jacobian rows (judged from the bodies' twists)
  double margin = 0.0;        // detection margin of the step's last detection
  double margin_balls = 0.0;  // the same for pairs of two balls (detection.margin_rule)
  // detection.verify_margin: detections after the first, each because the end velocities
  // outran the margin; and whether they still did after the last one allowed
  int projection_rounds = 0;      // scheme.projection: rounds this step (0: none needed)
  int projection_iterations = 0;  // their solver's iterations
  int redetections = 0;
  bool margin_outrun = false;
};

// A step whose solve stopped at its cap without one correct digit (a relative residual of 1 or
// more): its impulses are not an answer, and a run must not go on as if they were.
inline bool divergedSolve(const StepStats& s) {
  return s.cap_hit && !(s.residual < 1.0);
}
// The message for it, naming the step
std::string divergedSolveMessage(const StepStats& s);

// Calls visit(name, value) for each statistic of a step, in stats.csv's column order; the
// wall-clock timings (seconds, different on every run) only when `timings`. value is a long,
// int, double, bool or SolverStatus member of s.
template <class Visit>
void visitStepStats(const StepStats& s, bool timings, Visit&& visit) {
  visit("step", s.step);
  visit("t", s.t);
  visit("candidates", s.candidates);
  visit("active", s.active);
  visit("islands", s.islands);
  visit("iterations_stage1", s.iterations_stage1);
  visit("iterations_stage2", s.iterations_stage2);
  visit("updates", s.updates);
  visit("residual", s.residual);
  visit("cap_hit", s.cap_hit);
  visit("status", s.status);
  visit("penetration_max", s.penetration_max);
  visit("penetration_sum", s.penetration_sum);
  visit("penetration_count", s.penetration_count);
  visit("kinetic", s.kinetic);
  visit("potential", s.potential);
  visit("work_normal", s.work_normal);
  visit("work_tangent", s.work_tangent);
  visit("solves", s.solves);
  visit("deferred", s.deferred);
  visit("redetections", s.redetections);
  if (!timings) return;
  visit("t_detect", s.t_detect);
  visit("t_assemble", s.t_assemble);
  visit("t_solve", s.t_solve);
  visit("t_update", s.t_update);
}

}  // namespace sweep
