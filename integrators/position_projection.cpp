#include "integrators/position_projection.hpp"

#include <algorithm>
#include <chrono>
#include <limits>

#include "framework/configuration.hpp"
#include "framework/dynamics.hpp"
#include "framework/kinematics.hpp"
#include "framework/parallel.hpp"

namespace sweep {

ProjectionData::ProjectionData(const Model& model, const ContactModel& cmodel)
    : contacts(model, cmodel),
      problem_ws(model),
      zero(VectorX::Zero(model.nv)),
      dq(VectorX::Zero(model.nv)),
      q(model.nq) {
  problem.pack_rows = problem.pack_body_form = problem.compact_spheres = false;
}

namespace stepping {

namespace {

// The deepest violation at q: overlaps of the projection's contacts (but those marked in
// `held`, when given), and joint limits passed.
double deepestViolation(const Model& model, const ContactData& cdata, const VectorX& q,
                        const std::vector<char>* held, int threads) {
  const auto& contacts = cdata.contacts;
  double deepest = reduceInChunks(
      static_cast<long>(contacts.size()), threads, 0.0,
      [&](long c, double& part) {
        if (held == nullptr || !(*held)[c]) part = std::max(part, -contacts[c].gap);
      },
      [](double& total, double part) { total = std::max(total, part); });
  for (const JointLimit& limit : model.limits)
    deepest = std::max(deepest, -limit.side * (q[limit.q_index] - limit.bound));
  return deepest;
}

}  // namespace

void projectPositions(const StepModel& m, StepData& d) {
  const SchemeSettings::Projection& settings = m.settings.projection;
  d.stats.projection_rounds = d.stats.projection_iterations = 0;
  if (settings.max_rounds <= 0) return;
  const auto start = std::chrono::steady_clock::now();
  if (!d.projection) d.projection = std::make_unique<ProjectionData>(m.model, m.cmodel);
  ProjectionData& p = *d.projection;
  const double size = m.cmodel.smallest_size > 0.0 ? m.cmodel.smallest_size : 1.0;
  const double allowed = settings.tolerance * size;
  // the step's margins: what a round moves a body by (an overlap) is far below them
  const DetectionMargins margins{d.stats.margin_balls, d.stats.margin};
  // The scheme's own solver (Jean-Moreau's sweeps, with their acceleration; the staggered
  // scheme's stage 5a solver), stopped at a relative residual of 1e-3 at most: that error in
  // a displacement as deep as the tolerance is a thousandth of it.
  SolverSettings solver =
      m.settings.scheme == Scheme::MoreauJean ? m.settings.coulomb : m.settings.normal_stage;
  if (m.settings.scheme == Scheme::MoreauJean) solver.solver = StageSolver::Nlgs;
  solver.tolerance = std::max(solver.tolerance, 1e-3);
  const std::vector<ActuatorCommand>* commands =
      d.actuator_command.empty() ? nullptr : &d.actuator_command;
  for (int round = 0; round < settings.max_rounds; ++round) {
    forwardKinematics(m.model, d.model_data, d.q, p.zero);
    detectContacts(m.model, d.model_data, m.cmodel, p.contacts, d.t, margins, m.threads);
    const double deepest = deepestViolation(m.model, p.contacts, d.q, nullptr, m.threads);
    if (!(deepest > allowed)) break;
    // A round moves a body by about the deepest overlap: a candidate farther than twice that
    // cannot close in it (one that does is the next round's), and stays out of the program.
    const double reach = 2.0 * deepest + allowed;
    const int candidates = static_cast<int>(p.contacts.contacts.size());
    p.far.resize(candidates);
    forEachIndex(candidates, m.threads,
                 [&](int c) { p.far[c] = p.contacts.contacts[c].gap > reach; });
    // M(q) built and factored (the acceleration is not used)
    forwardDynamicsFromKinematics(m.model, d.model_data, p.zero, p.zero);
    assembleContactJacobian(m.model, d.model_data, m.cmodel, p.contacts, d.t,
                            std::numeric_limits<double>::infinity(), &p.far);
    // Held where they are (W_N^T dq >= 0), not counted as violations: contacts with
    // restitution, whose overlap is the last bounce's (VEL keeps an inelastic impact's h v
    // whole, an elastic one's shrinks with the bounces), and contacts whose bodies separate
    // fast enough to leave the overlap within the next step. Lifting either would hand a
    // rebound the overlap's potential energy: a ball with e = 0.9 kept bouncing at about
    // g h / (1 - e^2) where Moreau's scheme brings it to rest.
    const ContactJacobian& J = p.contacts.jacobian;
    const double h = m.settings.h;
    p.leaving.resize(candidates);
    forEachIndex(candidates, m.threads, [&](int c) {
      const double gap = p.contacts.contacts[c].gap;
      p.leaving[c] =
          !p.far[c] && gap < 0.0 &&
          (p.contacts.contacts[c].restitution > 0.0 || J.relativeVelocity(c, d.v).x() * h >= -gap);
    });
    // (far candidates overlap nothing)
    if (!(deepestViolation(m.model, p.contacts, d.q, &p.leaving, m.threads) > allowed)) break;
    assemblePositionProblem(m.model, d.model_data, m.cmodel, p.contacts, d.t, d.q, p.zero,
                            p.problem, p.problem_ws, &p.far, m.threads, commands);
    const int n = p.problem.size();
    // Overlaps are pushed back to half the tolerance, not to zero: a contact left a hair open
    // would be open for VEL at the next step, and a body at rest would fall h^2 g / 2 and
    // land again at every step.
    for (int c = 0; c < n; ++c) {
      if (p.problem.isBilateral(c)) continue;
      const int id = p.problem.contact[c];
      if (id >= 0 && p.leaving[id])
        p.problem.normal_bias[c] = 0.0;
      else
        p.problem.normal_bias[c] += 0.5 * allowed;
    }
    p.solver_ws.prepare(n, m.model.nv, static_cast<int>(m.model.components.size()));
    p.lambda.assign(n, 0.0);
    p.dq.setZero();
    const SolverStats solve = solveNormalStage(p.problem, solver, p.lambda, p.dq, p.solver_ws);
    ++d.stats.projection_rounds;
    d.stats.projection_iterations += solve.iterations;
    if (!p.dq.allFinite()) break;  // a failed solve moves nothing; the run's checks report it
    integrate(m.model, d.q, p.dq, p.q, m.threads);
    normalizeConfiguration(m.model, p.q, m.threads);
    d.q.swap(p.q);
  }
  d.stats.t_update +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace stepping
}  // namespace sweep
