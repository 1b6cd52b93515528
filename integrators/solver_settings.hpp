#pragma once
// What every contact solver shares: its settings, its exit status and its statistics. NLGS
// (integrators/nlgs.hpp), the convex stage solvers (integrators/convex_stages.hpp) and scheme
// A's coupled solve all take a SolverSettings and return a SolverStats.
#include <cstdint>
#include <string>

#include "framework/enum_names.hpp"

namespace sweep {

enum class SolverStatus { Converged, MaxIterations, Failed };
template <>
struct EnumNames<SolverStatus> {
  static constexpr EnumName<SolverStatus> table[] = {
      {SolverStatus::Converged, "converged"},
      {SolverStatus::MaxIterations, "max-iterations"},
      {SolverStatus::Failed, "failed"}};
};

// 3D local solver of scheme A (reference 2.3): Alart-Curnier Newton with a projection
// fallback (default), or the exact enumeration (a sign scan of the sliding direction).
enum class LocalSolver3d { AlartCurnier, Enumeration };
template <>
struct EnumNames<LocalSolver3d> {
  static constexpr EnumName<LocalSolver3d> table[] = {
      {LocalSolver3d::AlartCurnier, "alart-curnier"}, {LocalSolver3d::Enumeration, "enumeration"}};
};

// Acceleration of the Gauss-Seidel sweeps. Nncg is the nonsmooth nonlinear conjugate gradient
// of Silcowitz-Hansen, Niebe & Erleben (The Visual Computer 26, 2010): each Gauss-Seidel sweep
// is taken as a steepest-descent step and followed by a Fletcher-Reeves momentum,
//   x_{k+1} = GS(x_k) + beta_k p_{k-1},  p_k = GS(x_k) - x_k + beta_k p_{k-1},
//   beta_k = |GS(x_k) - x_k|^2 / |GS(x_{k-1}) - x_{k-1}|^2, restarted (beta = 0) when > 1.5,
// on the impulses and, through v = v_free + M^-1 H P, on the velocities. The residual is
// checked on the Gauss-Seidel iterate, so the solution returned is one sweep's output.
enum class NlgsAcceleration { None, Nncg };
template <>
struct EnumNames<NlgsAcceleration> {
  static constexpr EnumName<NlgsAcceleration> table[] = {{NlgsAcceleration::None, "none"},
                                                         {NlgsAcceleration::Nncg, "nncg"}};
};

// Solver of one of scheme B's stages: nonlinear Gauss-Seidel, or the stage solved as the
// convex quadratic program it is (integrators/convex_stages.hpp): MPRGP on box sets (stage
// 5a, 2D stage 5b), APGD when a block is a disc (3D stage 5b); Newton: active-set Newton steps
// on a sparse Cholesky factorization for box sets (integrators/projected_newton.hpp), APGD on
// discs. Auto, the default: Newton on 2D problems; on 3D ones NLGS with NNCG where every row
// joins free bodies, else MPRGP / APGD, the fastest on the funnel, the powder bed and the
// slider-crank (integrators/stage_solvers.cpp; docs/schemes.md, "Defaults and their status").
// Scheme A's coupled Coulomb problem is not convex and takes NLGS only.
enum class StageSolver { Nlgs, Mprgp, Newton, InteriorPoint, Auto };
template <>
struct EnumNames<StageSolver> {
  static constexpr EnumName<StageSolver> table[] = {{StageSolver::Auto, "auto"},
                                                    {StageSolver::Newton, "newton"},
                                                    {StageSolver::InteriorPoint, "interior-point"},
                                                    {StageSolver::Mprgp, "mprgp"},
                                                    {StageSolver::Nlgs, "nlgs"}};
};

struct SolverSettings {
  int max_iterations = 3000;
  StageSolver solver = StageSolver::Nlgs;
  // relative natural-map residual, checked once the relative impulse change is below it, and
  // every residual_check_interval sweeps (0: only then). In a hyperstatic pile the impulses
  // drift along a set of solutions long after the residual is met: on the powder heap the
  // change test alone cost 60 % more sweeps than the residual needs (docs/powder_bed.md).
  double tolerance = 1e-6;
  int residual_check_interval = 10;
  // omega; 1 is plain Gauss-Seidel, (0, 1) under- and (1, 2) over-relaxation. A row whose
  // local solution is zero takes it at once (sweeps.hpp, relaxedImpulse).
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

struct SolverStats {
  SolverStatus status = SolverStatus::Converged;
  int iterations = 0;      // sweeps (NLGS) or iterations (MPRGP, Newton) of the slowest island
  long updates = 0;        // local solves over all islands and sweeps (row visits)
  double residual = 0.0;   // relative natural-map residual at exit (worst island)
  int local_failures = 0;  // local problems without a consistent solution (Painleve cases)
};

}  // namespace sweep
