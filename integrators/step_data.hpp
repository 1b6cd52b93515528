#pragma once
// A step of either scheme as data and functions of it, after MuJoCo's mjModel / mjData and
// Pinocchio's Model / Data: StepModel is what a run never changes (the model, the contact
// model, the scheme's settings), StepData everything a step computes and the next step reads
// (the state, the contacts, the problem, the warm starts, the workspaces). The step's stages
// (namespace stepping) are functions of (StepModel, StepData); TimeStepper::step calls them in
// the order of the scheme's table (time_stepper.hpp).
#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include "contact/detection.hpp"
#include "framework/enum_names.hpp"
#include "integrators/actuation.hpp"
#include "integrators/contact_problem.hpp"
#include "integrators/nlgs.hpp"
#include "integrators/stage_solvers.hpp"
#include "integrators/step_stats.hpp"

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
  // floors, a fifth of the smallest moving shape's size with the default floor, or, if more,
  // speed_factor * h/2 * the fastest driven shape point's speed).
  bool screening = false;
  int screening_rounds = 8;
  double screening_gap = -1.0;
  // Position projection after each step (integrators/position_projection.hpp): up to
  // max_rounds rounds while an overlap (or a violated joint limit) is deeper than tolerance
  // times the smallest moving shape's size (ContactModel::smallest_size; without one, tolerance
  // in metres). 0 rounds: off.
  struct Projection {
    int max_rounds = 0;
    double tolerance = 1e-3;
  } projection;
  // 3D: contacts of free spheres as compact rows (ContactProblem::PackedSphere3d), 320 bytes
  // against 704 for the body-form rows, equal to them up to round-off; every sweep, operator
  // and residual of both schemes reads them directly. Unset (auto): compact.
  // The two row-storage choices are benchmark hooks (`sweep run --row-storage`, tests), not
  // scene keys: a scene's results do not depend on them.
  std::optional<bool> compact_sphere_rows;
  // false (an ablation): every solver reads every row from ContactProblem's generic arrays, no
  // packed 2D / 3D rows, body form or compact sphere rows; the results agree to round-off (2D:
  // to the bit). What each storage buys: docs/architecture.md, "Contact rows in two forms".
  bool packed_rows = true;
  // Threads for the solves (0: every core of the machine). The results are the same bits for
  // every count (SolverSettings::parallel_rows); it overrides the stages' own `threads`.
  int threads = 0;
  int threadCount() const;  // `threads`, or the machine's cores for 0
  bool compactSphereRows() const { return compact_sphere_rows.value_or(true); }

  void validate() const;
};

// Applied generalized forces tau(t, q, v) besides gravity (which the Model carries).
using AppliedForces =
    std::function<void(double t, const VectorX& q, const VectorX& v, VectorX& tau)>;

// What a run never changes. The settings' thread counts are resolved (every stage's `threads`
// is SchemeSettings::threadCount()).
struct StepModel {
  StepModel(const Model& model, const ContactModel& cmodel, const SchemeSettings& settings,
            AppliedForces forces);
  const Model& model;
  const ContactModel& cmodel;
  SchemeSettings settings;
  AppliedForces forces;
  bool constraint_friction = false;    // a constraint by functions has friction: 5b runs
  int threads = 1;                     // settings.threadCount()
  std::vector<double> component_mass;  // each body tree's mass (0 for systems by equations)
  double h() const { return settings.h; }
};

// A scheme-B warm start of one row: stage-5a normal impulse, bilateral correction, tangential
// impulse.
struct StagedImpulse {
  double normal = 0.0;
  double delta = 0.0;
  Vector2 tangent = Vector2::Zero();
};

// scheme.projection's contacts, problem and workspaces at q_{k+1}, apart from the step's own
// (whose contacts are the next step's warm starts).
struct ProjectionData {
  ProjectionData(const Model& model, const ContactModel& cmodel);
  ContactData contacts;
  ContactProblem problem;
  ContactProblemWorkspace problem_ws;
  SolverWorkspace solver_ws;
  VectorX zero, dq, q;
  std::vector<double> lambda;
  std::vector<char> far;      // by contact: too far to close in a round, left out of it
  std::vector<char> leaving;  // by contact: held, not pushed out (restitution, separating)
};

// Everything a step computes. Vectors "by contact" are aligned with
// contact_data.contacts (their previous_* twins with contact_data.previous); "by row" with
// problem's rows. Sized between steps: the solvers allocate nothing inside their iterations.
struct StepData {
  StepData(const Model& model, const ContactModel& cmodel, const SchemeSettings& settings);

  // the state: q_k, v_k at the start of a step, q_{k+1}, v_{k+1} after it
  double t = 0.0;
  VectorX q, v;
  // the scene's size at reset (stepping::checkRunaway): the bodies' spread, at least twice the
  // smallest moving shape; 0 where there is nothing to measure it by
  double scene_extent = 0.0;
  VectorX q_m;               // 1: the midpoint configuration
  VectorX v_free;            // 4: the contact-free velocity; 5 turns it into v_{k+1}
  VectorX tau;               // 4: applied forces besides gravity at (t_m, q_m, v_k)
  Data model_data;           // kinematics and mass matrix (at q_m during the step)
  ContactData contact_data;  // 2: contacts and their Jacobian rows
  ContactProblem problem;    // 3: the rows of the solve
  ContactProblemWorkspace problem_ws;
  // a distributed run (integrators/distributed_stepper.hpp): per body, the rank that owns it
  // (-1: not held here), and this rank. Detection keeps the contacts whose bodies' lowest
  // owner is this rank: a contact across a cut goes to the lower rank, so only the higher
  // rank's grains along the cut are shared. Empty: every contact.
  std::vector<int> body_rank;
  int rank = 0;
  // a distributed step's speeds of the whole scene, combined over the ranks, for the detection
  // margins and the margin check (every rank then detects as the single process); null: this
  // process's bodies are the scene
  std::function<MarginSpeeds()> scene_speeds;
  SolverWorkspace solver_ws;
  StepStats stats;

  // impulses by contact: this step's, and the last step's (warm starts)
  std::vector<Vector3> impulse, previous_impulse;
  std::vector<StagedImpulse> staged, previous_staged;  // scheme B
  std::vector<Vector2> rolling, previous_rolling;      // empty without rolling resistance
  // rows of the model itself persist by index: joint limits (Model::limits), constraints by
  // functions (Model::constraints), and both as scheme-B rows (limits, then constraints)
  std::vector<double> limit_impulse;
  std::vector<Vector3> constraint_impulse;
  std::vector<StagedImpulse> limit_staged;

  // 5, by row: impulses (normal, tangents), rolling impulses; scheme B's stage values
  std::vector<Vector3> P;
  std::vector<Vector2> R;
  // by row: h F of an adhesive row (ContactLaw), empty when the scene has no adhesion. The
  // solvers work on P~ = P + (h F, 0, 0) >= 0; P is P~ less h F again after the solve.
  std::vector<double> adhesion_impulse;
  std::vector<double> lambda_N, delta;
  std::vector<Vector2> lambda_T;
  // FrictionStageOptions::threshold_updates: v after stage 5a, the rounds' threshold impulses
  VectorX v_stage1;
  std::vector<double> threshold_impulse;
  std::vector<double> end_gap;                 // gaps at q_{k+1}, by contact (diagnostics)
  std::unique_ptr<ProjectionData> projection;  // scheme.projection on

  // actuators (Model::actuators, integrators/actuation.hpp), by actuator: Python's commands,
  // the explicit torque tau_e and the implicit damping c of the step, whether the step holds it
  // at its limit, the torque applied over the last step; h c by velocity; the components
  // holding an actuated joint; the servo's target position at the step's end (NaN: none)
  std::vector<ActuatorCommand> actuator_command;
  std::vector<double> actuator_explicit, actuator_damping, actuator_torque, actuator_target;
  std::vector<char> actuator_saturated;
  std::vector<signed char> actuator_held;  // +-1: held at +-max_torque for this step's solves
  VectorX added_mass;
  std::vector<char> actuated_component;

  // candidate screening, by contact: left out of the solve, solved this step, the law's bias
  // of each left out, left out without Jacobian rows (judged from its bodies' twists)
  std::vector<char> deferred, solved;
  std::vector<double> screening_bias;
  std::vector<char> unassembled;
  std::vector<char> jacobian_skip;  // unassembled, or written in body form by the assembly
  bool jacobian_stale = false;      // an admitted contact has no rows yet
  // world twists of the root bodies at the step's start, contact-free, and predicted or final
  std::vector<Vector6> start_twist, free_twist, end_twist;
  VectorX v_contact_free;
  VectorX contact_dv;  // the contacts' velocity change in the last step
  VectorX v_predicted;
  // detection.verify_margin: the warm starts the step began with, for a step done again
  VectorX contact_dv_start;
  std::vector<double> limit_impulse_start;
  std::vector<Vector3> constraint_impulse_start;
  std::vector<StagedImpulse> limit_staged_start;
};

// The owner of problem row c: a contact (index into contact_data.contacts), a joint limit or a
// constraint by functions (ContactProblem::contact codes the last two as -1 - m, limits first).
struct RowOwner {
  enum Kind { Contact, Limit, Constraint } kind;
  int index;  // into contacts, Model::limits or Model::constraints
};
inline RowOwner rowOwner(const Model& model, int id) {
  if (id >= 0) return {RowOwner::Contact, id};
  const int m = -1 - id, limits = static_cast<int>(model.limits.size());
  return m < limits ? RowOwner{RowOwner::Limit, m} : RowOwner{RowOwner::Constraint, m - limits};
}

// The stages of a step (time_stepper.hpp's table): time_stepper.cpp (reset), step_detection.cpp
// (1, 2), step_assembly.cpp (4, 3), step_solve.cpp (5) and step_update.cpp (6, the checks).
namespace stepping {
// wall seconds since `start`: the stages' times in StepStats
inline double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}
void reset(const StepModel& m, StepData& d, double t, const VectorX& q, const VectorX& v);
// after the update: throws RunawayError (framework/error.hpp), naming the step and the body, where
// a body tree's kinetic energy is that of its mass crossing the scene 100 times in one step
void checkRunaway(const StepModel& m, const StepData& d);
void midpoint(const StepModel& m, StepData& d);  // 1
// a distributed step's owner of a contact: the lowest rank that owns one of its bodies with
// dofs (StepData::body_rank), -1 where body_rank knows none
int contactOwner(const std::vector<int>& body_rank, const Contact& contact);
// 2, with margins of at least `at_least`
void detect(const StepModel& m, StepData& d, const DetectionMargins& at_least = {});
// back to the state before detect(m, d): the contact lists and warm starts of the last step
void undoDetection(const StepModel& m, StepData& d);
void freeVelocity(const StepModel& m, StepData& d);      // 4 (M(q_m) factored here; 3 needs it)
void assemble(const StepModel& m, StepData& d);          // 3: Jacobian, then the problem
void assembleJacobian(const StepModel& m, StepData& d);  // rows of the contacts not unassembled
void assembleProblem(const StepModel& m, StepData& d);   // the contacts not deferred, warm-started
void solve(const StepModel& m, StepData& d);             // 5, with candidate screening when set
// 5 as solve() with the single solve given: solve_once solves the assembled problem once; agree
// turns this process's count of admitted candidates into the count every process acts on
// (the sum over ranks; the count itself in one process); adhesion_in_solve: solve_once adds
// the adhesive rows' -h F to the velocities itself (a distributed solve), else v_free has it.
// Screening's rounds (every candidate at the last) repeat the solve until agree gives 0.
void solveScreened(const StepModel& m, StepData& d, const std::function<void()>& solve_once,
                   const std::function<int(int)>& agree, bool adhesion_in_solve);
void solveMoreauJean(const StepModel& m, StepData& d);  // 5, scheme A
void solveCatchingUp(const StepModel& m, StepData& d);  // 5, scheme B
// scheme B's step 5 with its two stages' solves given: the stage-5a solve of d.lambda_N from v,
// and the stage-5b solve of d.delta, d.lambda_T (and d.R) from v1 with the thresholds'
// impulses (null: d.lambda_N). solveCatchingUp(m, d) passes the single process's stage solvers.
struct StageSolves {
  std::function<SolverStats(VectorX& v)> normal;
  std::function<SolverStats(const std::vector<double>* threshold_impulse, VectorX& v)> friction;
};
void solveCatchingUp(const StepModel& m, StepData& d, const StageSolves& stages);
void keepImpulses(const StepModel& m, StepData& d);  // by contact: the next solve's warm start
// Adhesion (ContactLaw; docs/schemes.md, "Adhesion"): on a row with P_N >= -h F the solvers see
// P~ = P + (h F, 0, 0) >= 0, the plain law with the thresholds mu P~_N and mu_r R* P~_N, and a
// contact-free velocity that carries the impulse -h F of every adhesive row.
// shiftForAdhesion: d.adhesion_impulse (h F by row) and the warm starts d.P shifted by it;
// applyAdhesionImpulses: the rows' -h F added to v; unshiftAdhesion: P = P~ - h F again.
void shiftForAdhesion(const StepModel& m, StepData& d);
void applyAdhesionImpulses(const StepData& d, VectorX& v);
void unshiftAdhesion(StepData& d);
// screening: contacts left out that break their law at the solve's velocities join
int admitViolators(const StepModel& m, StepData& d);  // returns how many
// detection.verify_margin: the margins a detection needs for the end velocities of the solve
// just done (zero where the step's margins cover them); 2 to 5 again from q_m with them
DetectionMargins marginNeeded(const StepModel& m, StepData& d);
// stages_2_to_5(margins) runs them on the step's data: by default detect with the margins,
// freeVelocity, assemble and solve; a distributed step passes its own
void redoStep(const StepModel& m, StepData& d, const DetectionMargins& margins,
              const std::function<void(const DetectionMargins&)>& stages_2_to_5 = {});
void update(const StepModel& m, StepData& d);    // 6
void diagnose(const StepModel& m, StepData& d);  // energies and penetrations at q_{k+1}
double metricKinetic(const StepModel& m, StepData& d, const VectorX& v);  // 1/2 v^T M(q_m) v
}  // namespace stepping

}  // namespace sweep
