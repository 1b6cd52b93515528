#pragma once
// Nonlinear Gauss-Seidel solvers on a ContactProblem, matrix-free: v is kept current and each
// local update adds M^-1 H_c dP_c (reference sections 2.4-2.5).
//
// - solveCoulombNlgs: scheme A's coupled Newton-Coulomb problem, exact local solves.
// - solveNormalStage: scheme B stage 5a, frictionless shock law on M^-1-normalized normals,
//   closed-form local update Lambda <- [Lambda - xi]_+.
// - solveFrictionStage: scheme B stage 5b, friction with thresholds frozen from 5a.
//
// Solvers never print and never allocate inside their sweeps (workspaces are sized by
// prepare(), between steps). Each returns a status and its statistics.
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "integrators/contact_problem.hpp"
#include "integrators/mprgp.hpp"
#include "integrators/projected_newton.hpp"

namespace sweep {

enum class SolverStatus { Converged, MaxIterations, Failed };
const char* solverStatusName(SolverStatus status);

// 3D local solver of scheme A (reference 2.3): Alart-Curnier Newton with a projection
// fallback (default), or the exact enumeration (a sign scan of the sliding direction).
enum class LocalSolver3d { AlartCurnier, Enumeration };

// Acceleration of scheme A's sweeps. Nncg is the nonsmooth nonlinear conjugate gradient of
// Silcowitz-Hansen, Niebe & Erleben (The Visual Computer 26, 2010): each Gauss-Seidel sweep
// is taken as a steepest-descent step and followed by a Fletcher-Reeves momentum,
//   x_{k+1} = GS(x_k) + beta_k p_{k-1},  p_k = GS(x_k) - x_k + beta_k p_{k-1},
//   beta_k = |GS(x_k) - x_k|^2 / |GS(x_{k-1}) - x_{k-1}|^2, restarted (beta = 0) when > 1.5,
// on the impulses and, through v = v_free + M^-1 H P, on the velocities. The residual is
// checked on the Gauss-Seidel iterate, so the solution returned is one sweep's output.
enum class NlgsAcceleration { None, Nncg };
const char* nlgsAccelerationName(NlgsAcceleration acceleration);

// Solver of one of scheme B's stages: nonlinear Gauss-Seidel, or the stage solved as the
// convex quadratic program it is (integrators/convex_stages.hpp): MPRGP on box sets (stage
// 5a, 2D stage 5b), APGD when a block is a disc (3D stage 5b); Newton: active-set Newton steps
// on a sparse Cholesky factorization for box sets (integrators/projected_newton.hpp), APGD on
// discs. Auto, the default: Newton on 2D problems, MPRGP on 3D ones, the faster of the two on
// the funnel, the powder bed and the slider-crank (docs/schemes.md, "Convex stage solvers").
// Scheme A's coupled Coulomb problem is not convex and takes NLGS only.
enum class StageSolver { Nlgs, Mprgp, Newton, Auto };
const char* stageSolverName(StageSolver solver);  // "nlgs", "mprgp", "newton", "auto"

struct NlgsSettings {
  int max_iterations = 3000;
  StageSolver solver = StageSolver::Nlgs;
  // relative natural-map residual, checked once the relative impulse change is below it, and
  // every residual_check_interval sweeps (0: only then). In a hyperstatic pile the impulses
  // drift along a set of solutions long after the residual is met: on the powder heap the
  // change test alone cost 60 % more sweeps than the residual needs (docs/powder_bed.md).
  double tolerance = 1e-6;
  int residual_check_interval = 10;
  // omega; 1 is plain Gauss-Seidel, (0, 1) under- and (1, 2) over-relaxation. A row whose
  // local solution is zero takes it at once (nlgs.cpp, relaxedImpulse).
  double relaxation = 1.0;
  bool shuffle = false;  // random contact order every sweep (seeded, deterministic)
  std::uint32_t seed = 1;
  LocalSolver3d local_solver_3d = LocalSolver3d::AlartCurnier;
  NlgsAcceleration acceleration = NlgsAcceleration::None;
  // An island of at least parallel_rows rows on packed rows, unshuffled, is swept in colour
  // order: greedy colours by the components the rows move, taken in the rows' order, so that
  // rows of one colour share no velocity and are updated by `threads` threads at once. The
  // order and the sums (per fixed chunk of rows, added in chunk order) do not depend on the
  // thread count: the same bits for every count. Smaller islands keep the rows' order.
  int threads = 1;
  int parallel_rows = 4096;

  void validate(const std::string& owner) const;  // InputError naming the field
};

struct NlgsStats {
  SolverStatus status = SolverStatus::Converged;
  int iterations = 0;      // sweeps of the slowest island
  long updates = 0;        // local solves over all islands and sweeps
  double residual = 0.0;   // relative natural-map residual at exit (worst island)
  int local_failures = 0;  // local problems without a consistent solution (Painleve cases)
};

struct NlgsWorkspace {
  // components: the model's count (Model::components), for the coloured sweeps
  void prepare(int contacts, int nv = 0, int components = 0);
  std::vector<int> order;
  std::mt19937 rng;
  std::vector<double> threshold;    // friction stage: mu lambda_N per contact
  std::vector<double> held_normal;  // friction stage: normal velocity after stage 5a
  std::vector<double> y;            // friction stage: normal-velocity part of v1, N_A y
  std::vector<Vector2> offset;      // friction stage: W_T^T v_N per contact
  VectorX v_normal;                 // friction stage: v_N = M^-1 N_A y
  std::vector<Vector2> coupling;    // friction stage: W_TN / W_NN per contact
  std::vector<Matrix2> schur;       // friction stage: W_TT - W_TN W_NT / W_NN per contact
  // NNCG: the iterate before the sweep and the search direction, per contact and per dof of
  // the island (island_dofs; dof_stamp marks them without clearing between islands)
  std::vector<double> impulse_before, impulse_direction;
  VectorX v_before, v_direction;
  std::vector<int> island_dofs, dof_stamp;
  int stamp = 0;
  // coloured sweeps (NlgsSettings::parallel_rows): the colours taken at each component (a bit
  // each), each block's colour, the blocks in colour order as chunks (colour_chunk[k] ..
  // colour_chunk[k + 1] for colour k, the serial one k = 64 the last; chunk j is
  // order[chunk_begin[j], chunk_begin[j + 1])) and each chunk's sums
  std::vector<std::uint64_t> component_colours;
  std::vector<int> row_colour, coloured_order;
  std::vector<int> colour_chunk, chunk_begin;
  std::vector<double> chunk_change2, chunk_size2;
  std::vector<int> chunk_failures;
  // the convex stage solvers' (every StageSolver but Nlgs): the program's variables and sets, and
  // per row its variables (-1: none) and their scales
  struct Convex {
    MprgpWorkspace mprgp;
    // one per program, so that a pattern that holds from step to step keeps its analysis
    ProjectedNewtonWorkspace newton_normal, newton_projection, newton_friction;
    SeparableSet set;
    std::vector<double> x;
    std::vector<int> normal_var, tangent_var, rolling_var;
    std::vector<double> normal_scale, rolling_scale, target;
    std::vector<Matrix2> tangent_map;  // physical tangential impulse = tangent_map * x_T
    VectorX v_normal;
    std::vector<int> dofs;  // the velocities the rows reach (QpOperator::dofs)
    std::vector<int> dof_stamp;
    int stamp = 0;
  } convex;
};

// v: in v_free, out the velocity after the impulses. P: in the warm start, out the impulses.
// rolling (problems with rolling rows): in the warm start, out the rolling torque impulses,
// bounded by rolling_bound times P_N and solved in the same sweeps.
NlgsStats solveCoulombNlgs(const ContactProblem& problem, const NlgsSettings& settings,
                           std::vector<Vector3>& P, VectorX& v, NlgsWorkspace& workspace,
                           std::vector<Vector2>* rolling = nullptr);

// Stage 5a. lambda_N: in the warm start, out the physical normal impulses.
NlgsStats solveNormalStage(const ContactProblem& problem, const NlgsSettings& settings,
                           std::vector<double>& lambda_N, VectorX& v, NlgsWorkspace& workspace);

// Tangents of scheme B's friction stage (reference 4.3).
enum class TangentMode {
  Global,  // tangential reactions M^-1-orthogonal to every closed contact's normal: normal
           // velocities of closed contacts held fixed by bilateral corrections
  Local,   // each tangent M^-1-orthogonal to its own normal only
  None,    // plain tangents (ablation)
};
enum class FrictionThreshold {
  Physical,  // |lambda_T| <= mu lambda_N on physical impulses
  Metric,    // |R_T|_{M^-1} <= mu |R_N|_{M^-1}
};
// GLOBAL mode, stage 5b: the contacts stage 5a left without a normal impulse (open, or closed
// with none) [R]
enum class OpenContacts {
  Unilateral,  // each gets a normal correction delta >= 0 and the stage-5a normal law: friction
               // elsewhere may open such a contact but not push it closed past its law
  Free,        // nothing holds them (the reconstruction as written): friction may drive bodies
               // into them, and VEL never pushes the overlap back out
};

const char* tangentModeName(TangentMode mode);
const char* frictionThresholdName(FrictionThreshold threshold);
const char* openContactsName(OpenContacts open);

struct FrictionStageOptions {
  TangentMode tangents = TangentMode::Global;
  FrictionThreshold threshold = FrictionThreshold::Physical;
  OpenContacts open_contacts = OpenContacts::Unilateral;
  // GLOBAL's residual measures each held row's normal drift against the normal impulse the
  // row carries; false: against the tangential impulses only, which sweeps rows without
  // friction to the cap (docs/schemes.md)
  bool residual_scale_with_normal = true;
  // Rounds of stage 5b after the first, each with the thresholds of the held rows taken from
  // the previous round's total normal impulse, S_c = mu_c (lambda_N,c + delta_c), from v1 and
  // warm-started [R]: a fixed point on the thresholds, so that the normal impulse friction
  // itself calls for (a wedge) can lock (docs/schemes.md, "Threshold updates"). 0: the
  // reference's frozen thresholds.
  int threshold_updates = 0;
};

// Stage 5b. rolling: as for solveCoulombNlgs, the bound taken from the stage-5a lambda_N.
// lambda_N: the normal impulses of stage 5a (thresholds mu lambda_N). delta: in the
// warm start, out the normal corrections of GLOBAL mode (zero otherwise): bilateral on the
// contacts with lambda_N > 0, >= 0 on the others (OpenContacts::Unilateral).
// lambda_T: in the warm start, out the tangential impulses. v: in v1 (after 5a), out v2.
// The impulse on the rows H of contact c is then
//   (lambda_N + delta + tangentNormalPart(...), lambda_T).
// threshold_impulse: the normal impulse each threshold is taken from, S_c = mu_c times it
// (null: lambda_N; rolling bounds always take lambda_N).
NlgsStats solveFrictionStage(const ContactProblem& problem, const NlgsSettings& settings,
                             const FrictionStageOptions& options,
                             const std::vector<double>& lambda_N, std::vector<double>& delta,
                             std::vector<Vector2>& lambda_T, VectorX& v, NlgsWorkspace& workspace,
                             std::vector<Vector2>* rolling = nullptr,
                             const std::vector<double>* threshold_impulse = nullptr);

// Contact c's blocks for stage 5b: W_TN / W_NN and the Schur complement W_TT - W_TN W_NT / W_NN
// (2D: the second tangent's entries zero, its diagonal 1, unused).
struct FrictionBlock {
  Vector2 coupling;
  Matrix2 schur;
};
FrictionBlock frictionBlock(const ContactProblem& problem, int c);

// Stage 5b's per-contact setup, for both of its solvers: the blocks above (workspace coupling,
// schur), the thresholds S_c (threshold_impulse or lambda_N times mu; METRIC's 2D factor) and
// the normal velocities at v1 that GLOBAL holds.
void prepareFrictionStage(const ContactProblem& problem, const FrictionStageOptions& options,
                          const std::vector<double>& lambda_N,
                          const std::vector<double>* threshold_impulse, const VectorX& v1,
                          NlgsWorkspace& workspace);

// The W_N component of LOCAL tangents (t~ = W_T - W_N W_NT / W_NN) times lambda_T; zero in
// the other modes.
double tangentNormalPart(const ContactProblem& problem, int c, const FrictionStageOptions& options,
                         const Vector2& lambda_T);

}  // namespace sweep
