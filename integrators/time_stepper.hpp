#pragma once
// The two NSCD time-stepping schemes on one pipeline. Steps 1, 2, 4 and 6 are shared; steps
// 3 and 5 differ (reference: ../shared/reference/schemes.md, docs/schemes.md).
//
// Scheme A, Jean-Moreau (Moreau 1999, "Numerical aspects of the sweeping process", CMAME 177;
// Jean 1999, "The non-smooth contact dynamics method", CMAME 177), midpoint form:
//   1  q_m = q_k (+) h/2 v_k,  t_m = t_k + h/2
//   2  contacts, gaps g, frames at q_m
//   3  H_c = [W_N W_T](q_m), W_cc = H_c^T M(q_m)^-1 H_c
//   4  v_free = v_k + h M(q_m)^-1 (tau - b(q_m, v_k))
//   5  v_{k+1} = v_free + M^-1 sum_c H_c P_c with, for every c in the index set,
//      U*_N = U_N(k+1) + e U_N(k) (+ gap term),  0 <= U*_N _|_ P_N >= 0  and Coulomb's law on
//      P_T, solved together by NLGS (cap 3000)
//   6  q_{k+1} = q_m (+) h/2 v_{k+1}
//
// Scheme B, the staggered configuration-space "catching-up" scheme (Charles, Casenave &
// Glocker 2018, "A catching-up algorithm for multibody dynamics with impacts and dry
// friction", CMAME 334, 208-237), as reconstructed in the reference, section 4:
//   3  normals scaled to unit M^-1 norm, nhat_c = W_N,c / sqrt(W_NN,c); tangents made
//      M^-1-orthogonal to the normals (flag: global | local | none)
//   5a frictionless shock law on the scaled normals, projected Gauss-Seidel (cap 1500):
//      0 <= nhat^T v1 + e-term (+ gap term) _|_ Lambda >= 0
//   5b friction with thresholds S_c = mu_c lambda_N,c frozen from 5a, maximal dissipation on
//      the tangential part of the motion (cap 1500); in global mode the normal velocities of
//      closed contacts are held at their 5a values by bilateral corrections.
#include <functional>
#include <optional>
#include <vector>

#include "contact/detection.hpp"
#include "integrators/contact_problem.hpp"
#include "integrators/nlgs.hpp"
#include "integrators/stage_solvers.hpp"

#include "framework/enum_names.hpp"

namespace sweep {

enum class Scheme { MoreauJean, CatchingUp };
Scheme schemeFromName(const std::string& name);  // InputError if unknown
template <>
struct EnumNames<Scheme> {
  static constexpr EnumName<Scheme> table[] = {{Scheme::MoreauJean, "moreau-jean"},
                                               {Scheme::CatchingUp, "catching-up"}};
};

struct SchemeSettings {
  Scheme scheme = Scheme::MoreauJean;
  double h = 1e-4;
  NormalLaw normal_law = NormalLaw::Vel;
  SolverSettings coulomb{3000};  // scheme A
  // scheme B's stages, solved as convex programs by default (docs/schemes.md, "Convex stage
  // solvers")
  SolverSettings normal_stage{1500, StageSolver::Auto};    // 5a
  SolverSettings friction_stage{1500, StageSolver::Auto};  // 5b
  FrictionStageOptions friction;                           // scheme B: tangents, threshold
  // Candidate screening (both schemes): a candidate that is not predicted to close within
  // the step and carried no impulse at the last one is left out of the solve; after it, each
  // one left out is checked against its law (U*_N(k+1) >= 0 with zero impulse, up to
  // margin_floor / tau) and the violators join for another solve, warm-started. After
  // screening_rounds rounds every candidate joins. The answer is a solution of the whole
  // candidate problem: a contact with zero impulse whose law holds is a solution of its row.
  // Pays where the laws with gap terms (IQS, POS) carry many open candidates.
  // screening_gap: candidates closer than this always join the first solve (< 0: 200 margin
  // floors, a fifth of the smallest moving shape's size with the default floor).
  bool screening = false;
  int screening_rounds = 8;
  double screening_gap = -1.0;
  // 3D: contacts of free spheres as compact rows (ContactProblem::PackedSphere3d), 320 bytes
  // against 704 for the body-form rows, equal to them up to round-off. Scheme A's sweeps read
  // them directly; scheme B's friction stage reads them through the generic path and has a
  // packed path for body-form rows only. Unset (auto): compact for scheme A, body form for B.
  std::optional<bool> compact_sphere_rows;
  // false (an ablation): every solver reads every row from ContactProblem's generic arrays, no
  // packed 2D / 3D rows, body form or compact sphere rows; the results agree to round-off (2D:
  // to the bit). What each storage buys: docs/architecture.md, "Contact rows in two forms".
  bool packed_rows = true;
  // Threads for the solves (0: every core of the machine). The results are the same bits for
  // every count (SolverSettings::parallel_rows); it overrides the stages' own `threads`.
  int threads = 0;
  int threadCount() const;  // `threads`, or the machine's cores for 0
  bool compactSphereRows() const {
    return compact_sphere_rows.value_or(scheme == Scheme::MoreauJean);
  }

  void validate() const;
};

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
  int redetections = 0;
  bool margin_outrun = false;
};

// Applied generalized forces tau(t, q, v) besides gravity (which the Model carries).
using AppliedForces =
    std::function<void(double t, const VectorX& q, const VectorX& v, VectorX& tau)>;

class TimeStepper {
 public:
  TimeStepper(const Model& model, const ContactModel& cmodel, const SchemeSettings& settings,
              AppliedForces forces = {});

  void reset(double t, const VectorX& q, const VectorX& v);
  const StepStats& step();

  // detection.verify_margin: detections per step after the first, at most; a step whose end
  // velocities still outrun the margin is flagged (StepStats::margin_outrun)
  static constexpr int kMaxRedetections = 2;

  double time() const { return t_; }
  const VectorX& q() const { return q_; }
  const VectorX& v() const { return v_; }
  const StepStats& stats() const { return stats_; }
  const SchemeSettings& settings() const { return settings_; }
  const ContactData& contactData() const { return cdata_; }
  const ContactProblem& problem() const { return problem_; }  // of the last step's solve
  // impulse (normal, tangents) of each contact of contactData().contacts in the last step
  const std::vector<Vector3>& impulses() const { return impulse_; }
  // rolling torque impulse of each contact in the last step (tangent axes; 2D: z), empty
  // when no law has rolling resistance
  const std::vector<Vector2>& rollingImpulses() const { return rolling_; }
  // impulse of each joint limit (Model::limits) in the last step
  const std::vector<double>& limitImpulses() const { return limit_impulse_; }
  // impulse (normal, tangents) of each constraint by functions (Model::constraints)
  const std::vector<Vector3>& constraintImpulses() const { return constraint_impulse_; }
  double energy();  // kinetic + potential at the current state

 private:
  void midpoint();                                     // 1
  void detect(const DetectionMargins& at_least = {});  // 2, with margins of at least these
  // detection.verify_margin: the margins `at_least` a detection needs for the end velocities
  // of the solve just done; zero where the step's margins cover them
  DetectionMargins marginNeeded();
  void redoStep(const DetectionMargins& margins);                      // 2 to 5 again, from q_m
  void freeVelocity();                                                 // 4
  void addSystemForces(double t, const VectorX& q, const VectorX& v);  // into tau_
  void assemble();          // 3: Jacobian, then the problem
  void assembleJacobian();  // 3: rows of the contacts not unassembled
  void assembleProblem();   // 3: the problem of the contacts not deferred, warm-started
  void solve();             // 5, with candidate screening when set
  void solveMoreauJean();   // 5, scheme A
  void solveCatchingUp();   // 5, scheme B
  void keepImpulses();      // the solve's impulses by contact: warm start of the next solve
  // contacts left out that break their law at the solve's velocities join (returns how many)
  int admitViolators();
  void update();  // 6
  void diagnose();

  const Model& model_;
  const ContactModel& cmodel_;
  SchemeSettings settings_;
  AppliedForces forces_;
  Data data_;
  ContactData cdata_;
  ContactProblem problem_;
  ContactProblemWorkspace problem_ws_;
  SolverWorkspace nlgs_ws_;
  StepStats stats_;

  double t_ = 0.0;
  VectorX q_, v_, q_m_, v_free_, tau_;
  std::vector<Vector3> impulse_, previous_impulse_;  // aligned with contacts / previous
  // scheme B warm starts, aligned the same way: stage-5a normal impulse, bilateral
  // correction, tangential impulse
  struct StagedImpulse {
    double normal = 0.0;
    double delta = 0.0;
    Vector2 tangent = Vector2::Zero();
  };
  std::vector<StagedImpulse> staged_, previous_staged_;
  std::vector<double> limit_impulse_;        // joint limits persist: warm start by index
  std::vector<Vector3> constraint_impulse_;  // so do constraints by functions
  std::vector<StagedImpulse> limit_staged_;  // limits, then constraints
  // warm-start value of problem row c (a contact's previous impulse, or a limit's)
  const StagedImpulse* previousStaged(int c) const;
  std::vector<Vector2> rolling_, previous_rolling_;  // aligned with contacts / previous
  std::vector<Vector2> R_;                           // problem rows
  std::vector<double> delta_;
  std::vector<Vector3> P_;  // problem rows
  std::vector<double> lambda_N_;
  // FrictionStageOptions::threshold_updates: v after stage 5a, and the rounds' threshold impulses
  VectorX v_stage1_;
  std::vector<double> threshold_impulse_;
  std::vector<Vector2> lambda_T_;
  std::vector<double> end_gap_;
  // candidate screening, aligned with contacts: left out of the solve, solved this step
  std::vector<char> deferred_, solved_;
  std::vector<double> screening_bias_;  // the law's bias of each contact left out
  // left out without Jacobian rows: judged from its bodies' twists
  std::vector<char> unassembled_;
  std::vector<char> jacobian_skip_;  // unassembled, or written in body form by the assembly
  bool jacobian_stale_ = false;      // an admitted contact has no rows yet
  // world twists of the root bodies at the step's start, contact-free, and predicted or final
  std::vector<Vector6> start_twist_, free_twist_, end_twist_;
  VectorX v_contact_free_;
  VectorX contact_dv_;  // the contacts' velocity change in the last step (screening)
  // detection.verify_margin: the warm starts a step began with, for a step done again
  VectorX contact_dv_start_;
  std::vector<double> limit_impulse_start_;
  std::vector<Vector3> constraint_impulse_start_;
  bool constraint_friction_ = false;  // a constraint by functions has friction: 5b runs
  std::vector<StagedImpulse> limit_staged_start_;
  VectorX v_predicted_;
  double metricKinetic(const VectorX& v);  // 1/2 v^T M(q_m) v
};

}  // namespace sweep
