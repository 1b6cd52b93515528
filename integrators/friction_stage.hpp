#pragma once
// Scheme B's friction stage (5b, reference 4.3) as both of its solvers see it: the choice of
// tangents and threshold, which rows the stage holds or guards, each contact's blocks, and
// the per-contact setup they share. NLGS sweeps it (integrators/nlgs.hpp), the convex solvers
// solve it as a program (integrators/convex_stages.hpp); integrators/stage_solvers.hpp picks.
#include <vector>

#include "integrators/contact_problem.hpp"
#include "integrators/solver_workspace.hpp"

#include "framework/enum_names.hpp"

namespace sweep {

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

template <>
struct EnumNames<TangentMode> {
  static constexpr EnumName<TangentMode> table[] = {
      {TangentMode::Global, "global"}, {TangentMode::Local, "local"}, {TangentMode::None, "none"}};
};
template <>
struct EnumNames<FrictionThreshold> {
  static constexpr EnumName<FrictionThreshold> table[] = {{FrictionThreshold::Physical, "physical"},
                                                          {FrictionThreshold::Metric, "metric"}};
};
template <>
struct EnumNames<OpenContacts> {
  static constexpr EnumName<OpenContacts> table[] = {{OpenContacts::Unilateral, "unilateral"},
                                                     {OpenContacts::Free, "free"}};
};

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

// What stage 5b does with a row's normal direction, for both of its solvers:
// - closed: stage 5a left a normal impulse on it (or it is bilateral, whatever its sign);
// - held (GLOBAL): its normal velocity stays at its stage-5a value, by a free correction
//   delta; frictionless rows (mu = 0 pairs, joint limits) included, since friction elsewhere
//   must not push them open or closed;
// - guarded (GLOBAL, OpenContacts::Unilateral): the other rows keep stage 5a's normal law,
//   U_N + bias >= 0 _|_ delta >= 0. Without it, friction at the held rows drives bodies into
//   the contacts 5a left open, and under VEL nothing pushes them out again; in a deep powder
//   heap that overlap grew to 38 um (docs/schemes.md, "Open contacts in stage 5b").
struct FrictionRowRule {
  const ContactProblem& problem;
  const FrictionStageOptions& options;
  const std::vector<double>& lambda_N;
  bool closed(int c) const { return lambda_N[c] > 0.0 || problem.isBilateral(c); }
  bool held(int c) const { return options.tangents == TangentMode::Global && closed(c); }
  bool guarded(int c) const {
    return options.tangents == TangentMode::Global &&
           options.open_contacts == OpenContacts::Unilateral && !closed(c);
  }
  // whether v_N, the M-projection of v1 on the closed normals, can be nonzero: with
  // U*_N = U_N (e = 0, VEL) the closed contacts have U_N = 0 after stage 5a, up to the
  // tolerance, and it vanishes
  bool needsProjection() const {
    if (options.tangents != TangentMode::Global) return false;
    for (int c = 0; c < problem.size(); ++c)
      if (closed(c) && problem.normal_bias[c] != 0.0) return true;
    return false;
  }
};

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
                          SolverWorkspace& workspace);

// The W_N component of LOCAL tangents (t~ = W_T - W_N W_NT / W_NN) times lambda_T; zero in
// the other modes.
double tangentNormalPart(const ContactProblem& problem, int c, const FrictionStageOptions& options,
                         const Vector2& lambda_T);

}  // namespace sweep
