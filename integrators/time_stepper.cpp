#include "integrators/time_stepper.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>

#include <omp.h>

#include "framework/configuration.hpp"
#include "framework/crba.hpp"
#include "framework/dynamics.hpp"
#include "framework/energy.hpp"
#include "framework/error.hpp"
#include "framework/kinematics.hpp"
#include "framework/parallel.hpp"
#include "integrators/position_projection.hpp"
#include "integrators/rows.hpp"
#include "integrators/screening.hpp"

namespace sweep {

std::string divergedSolveMessage(const StepStats& s) {
  std::ostringstream out;
  out << "step " << s.step << " (t = " << std::setprecision(17) << s.t
      << "): the contact solve stopped at its iteration cap with a relative residual of "
      << std::setprecision(3) << s.residual
      << ", not one digit right: its impulses are not an answer (raise the cap, shorten the "
         "step, or leave out the acceleration)";
  return out.str();
}

Scheme schemeFromName(const std::string& name) {
  if (const std::optional<Scheme> scheme = enumFromName<Scheme>(name)) return *scheme;
  throw InputError("scheme must be " + enumChoices<Scheme>() + ", got '" + name + "'");
}

int SchemeSettings::threadCount() const {
  return threads > 0 ? threads : std::max(1, omp_get_num_procs());
}

void SchemeSettings::validate() const {
  if (!(std::isfinite(h) && h > 0.0)) {
    std::ostringstream out;
    out << "dt must be > 0, got " << h;
    throw InputError(out.str());
  }
  if (threads < 0 || threads > 1024)
    throw InputError("threads must be in [0, 1024] (0: every core), got " +
                     std::to_string(threads));
  coulomb.validate("moreau_jean.solver");
  if (coulomb.solver != StageSolver::Nlgs)
    throw InputError(
        "scheme.coulomb.solver must be nlgs: Jean-Moreau's coupled Coulomb problem is not convex");
  normal_stage.validate("catching_up.normal_stage");
  friction_stage.validate("catching_up.friction_stage");
  if (friction.threshold_updates < 0 || friction.threshold_updates > 100)
    throw InputError("scheme.threshold_updates must be in [0, 100], got " +
                     std::to_string(friction.threshold_updates));
  if (std::isnan(screening_gap)) throw InputError("scheme.screening_gap must be a number, got nan");
  if (projection.max_rounds < 0 || projection.max_rounds > 100)
    throw InputError("scheme.projection.max_rounds must be in [0, 100], got " +
                     std::to_string(projection.max_rounds));
  if (!(projection.tolerance > 0.0) || !std::isfinite(projection.tolerance))
    throw InputError("scheme.projection.tolerance must be a positive number, got " +
                     std::to_string(projection.tolerance));
  if (screening_rounds < 1)
    throw InputError("scheme.screening_rounds must be >= 1, got " +
                     std::to_string(screening_rounds));
}

namespace {
using Clock = std::chrono::steady_clock;
double seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}
}  // namespace

StepModel::StepModel(const Model& model_, const ContactModel& cmodel_,
                     const SchemeSettings& settings_, AppliedForces forces_)
    : model(model_), cmodel(cmodel_), settings(settings_), forces(std::move(forces_)) {
  settings.validate();
  for (const ConstraintFunction& f : model.constraints) {
    if (cmodel.dimension == 3 && f.friction > 0.0 && !f.tangent2)
      throw InputError("constraint '" + f.name +
                       "': friction in a 3D problem needs a second tangent function");
    constraint_friction = constraint_friction || f.friction > 0.0;
  }
  threads = settings.threadCount();
  settings.coulomb.threads = settings.normal_stage.threads = settings.friction_stage.threads =
      threads;
  component_mass.assign(model.components.size(), 0.0);
  for (std::size_t c = 0; c < model.components.size(); ++c)
    for (int b = model.components[c].first_body; b < model.components[c].end_body; ++b)
      component_mass[c] += model.bodies[b].inertia.mass;
}

StepData::StepData(const Model& model, const ContactModel& cmodel, const SchemeSettings& settings)
    : q(model.neutralConfiguration()),
      v(VectorX::Zero(model.nv)),
      q_m(q),
      v_free(v),
      tau(VectorX::Zero(model.nv)),
      model_data(model),
      contact_data(model, cmodel),
      problem_ws(model) {
  problem.compact_spheres = settings.compactSphereRows();
  problem.pack_body_form = problem.pack_rows = settings.packed_rows;
  const std::size_t actuators = model.actuators.size();
  actuator_command.resize(actuators);
  actuator_explicit.assign(actuators, 0.0);
  actuator_damping.assign(actuators, 0.0);
  actuator_torque.assign(actuators, 0.0);
  actuator_target.assign(actuators, std::numeric_limits<double>::quiet_NaN());
  actuator_saturated.assign(actuators, 0);
  actuator_held.assign(actuators, 0);
  added_mass = VectorX::Zero(model.nv);
  actuated_component.assign(model.components.size(), 0);
  for (const JointActuator& a : model.actuators)
    actuated_component[model.bodies[a.body].component] = 1;
}

TimeStepper::TimeStepper(const Model& model, const ContactModel& cmodel,
                         const SchemeSettings& settings, AppliedForces forces)
    : m_(model, cmodel, settings, std::move(forces)), d_(model, cmodel, m_.settings) {}

void TimeStepper::reset(double t, const VectorX& q, const VectorX& v) {
  stepping::reset(m_, d_, t, q, v);
}

double TimeStepper::energy() {
  forwardKinematics(m_.model, d_.model_data, d_.q, d_.v);
  return kineticEnergy(m_.model, d_.model_data) + potentialEnergy(m_.model, d_.model_data);
}

const StepStats& TimeStepper::step() {
  using namespace stepping;
  const StepModel& m = m_;
  StepData& d = d_;
  d.stats.step += 1;
  d.model_data.threads = m.threads;
  const bool actuated = !m.model.actuators.empty();
  if (actuated) std::fill(d.actuator_held.begin(), d.actuator_held.end(), 0);
  midpoint(m, d);      // 1
  detect(m, d);        // 2
  freeVelocity(m, d);  // 4 (M(q_m) is factored here; stage 3 needs it)
  // VEL solves the closed contacts only, which the margin does not decide
  const bool verify_margin =
      m.cmodel.settings.verify_margin && m.settings.normal_law != NormalLaw::Vel;
  if (verify_margin || actuated) {
    d.contact_dv_start = d.contact_dv;
    d.limit_impulse_start = d.limit_impulse;
    d.constraint_impulse_start = d.constraint_impulse;
    d.limit_staged_start = d.limit_staged;
  }
  assemble(m, d);  // 3
  solve(m, d);     // 5
  // servos that the contacts pushed past their torque limits are held at them, and the step
  // solved again: each round holds at least one more
  for (std::size_t round = 0; actuated && round < m.model.actuators.size(); ++round)
    if (holdActuatorLimits(m, d))
      redoStep(m, d, {});
    else
      break;
  d.stats.redetections = 0;
  d.stats.margin_outrun = false;
  if (verify_margin) {
    for (DetectionMargins needed = marginNeeded(m, d); needed.balls > 0.0 || needed.others > 0.0;
         needed = marginNeeded(m, d)) {
      if (d.stats.redetections == kMaxRedetections) {
        d.stats.margin_outrun = true;
        break;
      }
      ++d.stats.redetections;
      redoStep(m, d, needed);
    }
  }
  update(m, d);  // 6
  projectPositions(m, d);
  checkRunaway(m, d);
  diagnose(m, d);
  // periodic boundaries: bodies that left the cell re-enter at the other side; after the
  // diagnostics, which evaluate the gaps of this step's contacts on this step's images
  wrapPeriodic(m.cmodel, d.q);
  return d.stats;
}

namespace stepping {

void reset(const StepModel& m, StepData& d, double t, const VectorX& q, const VectorX& v) {
  if (q.size() != m.model.nq || v.size() != m.model.nv || !q.allFinite() || !v.allFinite())
    throw InputError("initial state: q must have " + std::to_string(m.model.nq) + " and v " +
                     std::to_string(m.model.nv) + " finite entries");
  d.t = t;
  d.q = q;
  d.v = v;
  d.stats = StepStats{};
  d.stats.t = t;
  d.impulse.clear();
  d.previous_impulse.clear();
  d.staged.clear();
  d.previous_staged.clear();
  d.rolling.clear();
  d.previous_rolling.clear();
  d.limit_impulse.assign(m.model.limits.size(), 0.0);
  d.constraint_impulse.assign(m.model.constraints.size(), Vector3::Zero());
  d.limit_staged.assign(m.model.limits.size() + m.model.constraints.size(), StagedImpulse{});
  d.contact_dv.setZero(m.model.nv);
  d.contact_data = ContactData(m.model, m.cmodel);
  forwardKinematics(m.model, d.model_data, d.q, d.v);
  Eigen::AlignedBox3d spread;
  for (const Pose& pose : d.model_data.world_pose) spread.extend(pose.translation);
  d.scene_extent =
      std::max(spread.isEmpty() ? 0.0 : spread.diagonal().norm(), 2.0 * m.cmodel.smallest_size);
}

void checkRunaway(const StepModel& m, const StepData& d) {
  // A body tree whose kinetic energy is that of its mass crossing the scene kRunawayExtents
  // times in one step has run away (a diverging solve or position correction), long before its
  // coordinates grow large enough to break the collision library's bounding boxes.
  constexpr double kRunawayExtents = 100.0;
  if (!(d.scene_extent > 0.0)) return;
  const double speed = kRunawayExtents * d.scene_extent / m.h();
  const int trees = static_cast<int>(m.model.components.size() - m.model.systems.size());
  for (int c = 0; c < trees; ++c) {
    const Component& comp = m.model.components[c];
    const double mass = m.component_mass[c];
    if (comp.nv == 0 || !(mass > 0.0)) continue;
    const MatrixX& M = d.model_data.mass_blocks[c];  // at the step's midpoint
    double twice_kinetic = 0.0;
    if (comp.nv == 6) {  // a free body: a fixed-size product, no temporary
      const auto v_c = d.v.segment<6>(comp.v_index);
      twice_kinetic = v_c.dot(Eigen::Map<const Matrix6>(M.data()) * v_c);
    } else {
      const auto v_c = d.v.segment(comp.v_index, comp.nv);
      for (int j = 0; j < comp.nv; ++j) twice_kinetic += v_c[j] * M.col(j).dot(v_c);
    }
    if (!(twice_kinetic > mass * speed * speed)) continue;
    const Body& body = m.model.bodies[comp.first_body];
    std::ostringstream out;
    out << "step " << d.stats.step << " (t = " << d.t << " s): body '" << body.name
        << "' has run away: its kinetic energy " << 0.5 * twice_kinetic
        << " J is that of its mass moving at " << std::sqrt(twice_kinetic / mass) << " m/s, over "
        << kRunawayExtents << " times the scene's extent (" << d.scene_extent << " m) per step of "
        << m.h()
        << " s (a diverging solve or position correction, or forces far beyond the scene's "
           "scale)";
    throw RunawayError(out.str());
  }
}

void midpoint(const StepModel& m, StepData& d) {
  integrate(m.model, d.q, 0.5 * m.settings.h * d.v, d.q_m, m.threads);
}

namespace {
// a contact belongs to the lowest rank that owns one of its bodies with dofs
void keepOwnedContacts(const std::vector<int>& body_rank, int rank,
                       std::vector<Contact>& contacts) {
  auto owned = [&](const Contact& contact) {
    int lowest = -1;
    for (const BodyRef* body : {&contact.body_a, &contact.body_b})
      if (body->kind == BodyRef::Kind::Dynamic) {
        const int owner = body_rank[body->index];
        if (owner >= 0 && (lowest < 0 || owner < lowest)) lowest = owner;
      }
    return lowest == rank;
  };
  contacts.erase(std::remove_if(contacts.begin(), contacts.end(),
                                [&](const Contact& contact) { return !owned(contact); }),
                 contacts.end());
}
}  // namespace

void detect(const StepModel& m, StepData& d, const DetectionMargins& at_least) {
  const auto start = Clock::now();
  const double t_m = d.t + 0.5 * m.settings.h;
  forwardKinematics(m.model, d.model_data, d.q_m, d.v);
  DetectionMargins margins = detectionMargins(m.model, d.model_data, m.cmodel, m.settings.h, t_m);
  margins.others = std::max(margins.others, at_least.others);
  margins.balls = std::max(margins.balls, at_least.balls);
  d.stats.margin = margins.others;
  d.stats.margin_balls = margins.balls;
  detectContacts(m.model, d.model_data, m.cmodel, d.contact_data, t_m, margins, m.threads);
  if (!d.body_rank.empty()) keepOwnedContacts(d.body_rank, d.rank, d.contact_data.contacts);
  std::swap(d.impulse, d.previous_impulse);
  d.impulse.assign(d.contact_data.contacts.size(), Vector3::Zero());
  const int contacts = static_cast<int>(d.contact_data.contacts.size());
  d.contact_data.held.resize(contacts);
  const bool adhesive = m.cmodel.adhesive();  // a contact that pulled is held too
  forEachIndex(contacts, m.threads, [&](int id) {
    const int previous = d.contact_data.contacts[id].previous;
    d.contact_data.held[id] = previous >= 0 &&
                              previous < static_cast<int>(d.previous_impulse.size()) &&
                              (d.previous_impulse[previous].x() > 0.0 ||
                               (adhesive && d.previous_impulse[previous].x() < 0.0));
  });
  std::swap(d.staged, d.previous_staged);
  d.staged.assign(d.contact_data.contacts.size(), StagedImpulse{});
  if (m.cmodel.rolling) {
    std::swap(d.rolling, d.previous_rolling);
    d.rolling.assign(d.contact_data.contacts.size(), Vector2::Zero());
  }
  d.solved.assign(d.contact_data.contacts.size(), 0);
  d.stats.candidates = static_cast<int>(d.contact_data.contacts.size());
  d.stats.t_detect = seconds(start);
}

DetectionMargins marginNeeded(const StepModel& m, StepData& d) {
  // A pair left out had gap >= margin at q_m and moves by h/2 times its relative velocity
  // until d.q{k+1}: at most h/2 (e_a + e_b) <= h * (fastest end speed of a shape point), and
  // for two balls at most h * ballClosingSpeed at the end velocities.
  const double t_m = d.t + 0.5 * m.settings.h;
  forwardKinematics(m.model, d.model_data, d.q_m, d.v_free);
  // a state that stopped being finite is the run's to report, not a reason to detect again;
  // else the default rule (twice the speed) on the end velocities: one more detection, mostly
  auto needed = [&](double reach, double margin) {
    if (!std::isfinite(reach) || reach <= margin) return 0.0;
    return 2.0 * reach + m.cmodel.margin_floor;
  };
  DetectionMargins out;
  out.others = needed(m.settings.h * fastestShapeSpeed(m.model, d.model_data, m.cmodel, t_m),
                      d.stats.margin);
  out.balls = m.cmodel.settings.margin_rule == MarginRule::Relative
                  ? needed(m.settings.h * ballClosingSpeed(m.model, d.model_data, m.cmodel, t_m),
                           d.stats.margin_balls)
                  : out.others;  // one margin for every pair
  return out;
}

void redoStep(const StepModel& m, StepData& d, const DetectionMargins& margins) {
  // back to the state after midpoint(m, d): the detection swaps its lists and the warm starts
  // with the previous step's, so swap them back first (the solve's results are discarded)
  std::swap(d.contact_data.contacts, d.contact_data.previous);
  std::swap(d.impulse, d.previous_impulse);
  std::swap(d.staged, d.previous_staged);
  if (m.cmodel.rolling) std::swap(d.rolling, d.previous_rolling);
  d.contact_dv = d.contact_dv_start;
  d.limit_impulse = d.limit_impulse_start;
  d.constraint_impulse = d.constraint_impulse_start;
  d.limit_staged = d.limit_staged_start;
  // the step's cost counts every solve; its other figures are those of the last
  const StepStats before = d.stats;
  detect(m, d, margins);
  freeVelocity(m, d);
  assemble(m, d);
  solve(m, d);
  d.stats.t_detect += before.t_detect;
  d.stats.t_assemble += before.t_assemble;
  d.stats.t_solve += before.t_solve;
  d.stats.updates += before.updates;
  d.stats.solves += before.solves;
  d.stats.iterations_stage1 += before.iterations_stage1;
  d.stats.iterations_stage2 += before.iterations_stage2;
}

namespace {
void addSystemForces(const StepModel& m, StepData& d, double t, const VectorX& q,
                     const VectorX& v) {
  for (const Component& c : m.model.components) {
    if (c.system < 0 || !m.model.systems[c.system].forces) continue;
    const EquationSystem& system = m.model.systems[c.system];
    const VectorX f = system.forces(t, q.segment(c.q_index, c.nq), v.segment(c.v_index, c.nv));
    if (f.size() != c.nv || !f.allFinite())
      throw std::runtime_error("system '" + system.name + "': its forces must be " +
                               std::to_string(c.nv) + " finite values at t = " + std::to_string(t));
    d.tau.segment(c.v_index, c.nv) += f;
  }
}

}  // namespace

void freeVelocity(const StepModel& m, StepData& d) {
  const auto start = Clock::now();
  const double t_m = d.t + 0.5 * m.settings.h;
  d.tau.setZero();
  if (m.forces) m.forces(t_m, d.q_m, d.v, d.tau);
  addSystemForces(m, d, t_m, d.q_m, d.v);
  // detect(m, d) left the kinematics of data at (q_m, v); constant mass blocks (particles) are
  // skipped, the others rebuilt and factored
  if (!m.model.actuators.empty())
    actuatedFreeVelocity(m, d);
  else
    d.v_free =
        d.v + m.settings.h * forwardDynamicsFromKinematics(m.model, d.model_data, d.v, d.tau);
  d.stats.t_assemble = seconds(start);
}

void assembleJacobian(const StepModel& m, StepData& d) {
  const auto start = Clock::now();
  // forwardDynamics left the kinematics of data at q_m
  // VEL solves closed contacts only: the open candidates need no rows
  const bool vel = m.settings.normal_law == NormalLaw::Vel;
  const double max_gap = vel ? heldGap(m.cmodel) : std::numeric_limits<double>::infinity();
  // rows the problem writes in body form from the contacts need no Jacobian rows: free
  // particles, the bulk of a granular step (contact_problem.hpp, rowInBodyForm)
  const int contacts = static_cast<int>(d.contact_data.contacts.size());
  d.jacobian_skip.resize(contacts);
  if (m.cmodel.dimension == 3) findFreeParticles(m.model, d.model_data, m.cmodel, d.problem_ws);
  const int threads = m.threads;
  forEachIndex(contacts, threads, [&](int id) {
    d.jacobian_skip[id] =
        (vel && !closedForVel(m.cmodel, d.contact_data, id)) ||
        (!d.unassembled.empty() && d.unassembled[id]) ||
        (d.problem.pack_body_form &&
         rowInBodyForm(m.model, d.model_data, m.cmodel, d.contact_data.contacts[id], d.problem_ws));
  });
  assembleContactJacobian(m.model, d.model_data, m.cmodel, d.contact_data, d.t + 0.5 * m.settings.h,
                          max_gap, &d.jacobian_skip, threads);
  d.jacobian_stale = false;
  d.stats.t_assemble += seconds(start);
}

void assemble(const StepModel& m, StepData& d) {
  const auto start = Clock::now();
  const double t_m = d.t + 0.5 * m.settings.h;
  if (!m.settings.screening) {
    d.deferred.clear();
    d.unassembled.clear();
    assembleJacobian(m, d);
    assembleProblem(m, d);
    return;
  }
  // Round one leaves out the candidates that did not carry an impulse at the last step, are
  // farther than `near`, and are not predicted to break their law at the velocity of the
  // step's start, the contact-free one or the contact-free one plus the last step's contact
  // push. A powder heap under IQS at h = 1e-4 has 7 to 10 candidates per closed contact; of
  // the candidates the solve then admits, 99 % are within 1.5 um. `near` defaults to twice
  // that, a fifth of the smallest radius: one solve per step on the 35 000-sphere bed instead
  // of two (docs/powder_bed.md).
  const int contacts = static_cast<int>(d.contact_data.contacts.size());
  const double tau = 0.5 * m.settings.h, slack = m.cmodel.margin_floor;
  const double factor = m.cmodel.settings.speed_factor;
  const double near =
      m.settings.screening_gap >= 0.0 ? m.settings.screening_gap : 200.0 * m.cmodel.margin_floor;
  d.deferred.assign(contacts, 0);
  d.unassembled.assign(contacts, 0);
  d.screening_bias.resize(contacts);
  // an adhesive row pulls whether or not it closes: never left out (its impulse is in v_free)
  auto adhesive = [&](const Contact& contact) {
    return m.cmodel.adhesive() && adhesionForce(m.cmodel, contact) > 0.0;
  };
  if (d.contact_dv.size() != m.model.nv) d.contact_dv = VectorX::Zero(m.model.nv);
  d.v_predicted = d.v_free + d.contact_dv;  // the last step's contact push, repeated
  // Candidates between free bodies (and walls, driven bodies) are judged from their bodies'
  // twists, and the ones left out get no Jacobian rows: on the 35 000-sphere bed the rows of
  // half a million candidates cost a quarter of the step, in memory traffic alone.
  const int threads = m.threads;
  rootBodyTwists(m.model, d.model_data, d.v, d.start_twist, threads);
  rootBodyTwists(m.model, d.model_data, d.v_free, d.free_twist, threads);
  rootBodyTwists(m.model, d.model_data, d.v_predicted, d.end_twist, threads);
  auto leaveOut = [&](const Contact& contact, double u_start, double u_free, double u_pushed,
                      double& bias) {
    bias = normalBias(m.settings.normal_law, contact.restitution, u_start, contact.gap, tau);
    return tau * (bias + factor * std::min({u_start, u_free, u_pushed, 0.0})) > slack;
  };
  forEachIndex(contacts, threads, [&](int id) {
    const Contact& contact = d.contact_data.contacts[id];
    if (m.settings.normal_law == NormalLaw::Vel || contact.gap <= near || d.contact_data.held[id] ||
        adhesive(contact))
      return;
    std::array<double, 3> u;  // at the start, contact-free, contact-free plus the last push
    if (!normalVelocitiesFromTwists<3>(m.model, d.model_data, contact,
                                       {&d.start_twist, &d.free_twist, &d.end_twist}, t_m, u))
      return;
    if (leaveOut(contact, u[0], u[1], u[2], d.screening_bias[id]))
      d.unassembled[id] = d.deferred[id] = 1;
  });
  d.stats.t_assemble += seconds(start);
  assembleJacobian(m, d);
  // contacts with a link of a tree, from their Jacobian rows
  const ContactJacobian& J = d.contact_data.jacobian;
  forEachIndex(contacts, threads, [&](int id) {
    const Contact& contact = d.contact_data.contacts[id];
    if (betweenRoots(m.model, contact)) return;
    if (m.settings.normal_law == NormalLaw::Vel && !closedForVel(m.cmodel, d.contact_data, id))
      return;
    if (contact.gap <= near || d.contact_data.held[id] || adhesive(contact)) return;
    d.deferred[id] =
        leaveOut(contact, J.relativeVelocity(id, d.v).x(), J.relativeVelocity(id, d.v_free).x(),
                 J.relativeVelocity(id, d.v_predicted).x(), d.screening_bias[id]);
  });
  assembleProblem(m, d);
}

void assembleProblem(const StepModel& m, StepData& d) {
  const auto start = Clock::now();
  assembleContactProblem(m.model, d.model_data, m.cmodel, d.contact_data, d.t + 0.5 * m.settings.h,
                         m.settings.normal_law, 0.5 * m.settings.h, d.q_m, d.v, d.problem,
                         d.problem_ws, &d.v_free, d.deferred.empty() ? nullptr : &d.deferred,
                         m.threads, d.actuator_command.empty() ? nullptr : &d.actuator_command);
  const int n = d.problem.size();
  d.stats.active = n;
  d.stats.islands = d.problem.islandCount();
  d.solver_ws.prepare(n, m.model.nv, static_cast<int>(m.model.components.size()));
  // warm start from this step's last solve, or else the previous step's impulses of the same
  // contacts
  d.P.assign(n, Vector3::Zero());
  d.R.assign(d.problem.rolling ? n : 0, Vector2::Zero());
  forEachIndex(n, m.threads, [&](int c) {
    const int id = d.problem.contact[c];
    const RowOwner owner = rowOwner(m.model, id);
    if (owner.kind == RowOwner::Limit) {
      d.P[c].x() = d.limit_impulse[owner.index];
      return;
    }
    if (owner.kind == RowOwner::Constraint) {
      d.P[c] = d.constraint_impulse[owner.index];
      return;
    }
    if (d.solved[id]) {
      d.P[c] = d.impulse[id];
      if (d.problem.rolling) d.R[c] = d.rolling[id];
      return;
    }
    const int previous = d.contact_data.contacts[id].previous;
    if (previous >= 0 && previous < static_cast<int>(d.previous_impulse.size()))
      d.P[c] = d.previous_impulse[previous];
    if (d.problem.rolling && previous >= 0 &&
        previous < static_cast<int>(d.previous_rolling.size()))
      d.R[c] = d.previous_rolling[previous];
  });
  d.stats.t_assemble += seconds(start);
}

void update(const StepModel& m, StepData& d) {
  const auto start = Clock::now();
  if (!m.model.actuators.empty()) actuatorTorques(m, d);
  const int n = d.problem.size();
  // contact work with the local velocities of H(q_m) at the start and end of the step
  d.stats.work_normal = d.stats.work_tangent = 0.0;
  // packed 3D rows (scheme A's powder rows): one pass for U and U_r, the generic reads' sums
  // to the bit (rows without a rolling row carry R = 0)
  const RowReader rows(d.problem, RowReader::kPacked3d | RowReader::kSpheres3d);
  auto velocities = [&](int c, const VectorX& v, Vector3& u, Vector2& u_rolling) {
    rows.visit(c, [&](const auto& row) { row.velocity(v, u, u_rolling); });
  };
  // {normal, tangential} work, summed in chunks of rows: the same bits on any thread count
  using Work = std::array<double, 2>;
  const Work work = reduceInChunks(
      n, m.threads, Work{0.0, 0.0},
      [&](long c, Work& sum) {
        Vector3 u_end, u_start;
        Vector2 rolling_end = Vector2::Zero(), rolling_start = Vector2::Zero();
        velocities(c, d.v_free, u_end, rolling_end);
        const Vector3 u_mean = 0.5 * (d.problem.velocity_start[c] + u_end);
        sum[0] += d.P[c].x() * u_mean.x();
        sum[1] += d.P[c].tail<2>().dot(u_mean.tail<2>());
        if (d.problem.contact[c] >= 0 && d.problem.rolling) {
          velocities(c, d.v, u_start, rolling_start);
          sum[1] += d.R[c].dot(0.5 * (rolling_start + rolling_end));
        }
      },
      [](Work& total, const Work& part) {
        total[0] += part[0];
        total[1] += part[1];
      });
  d.stats.work_normal = work[0];
  d.stats.work_tangent = work[1];
  d.v = d.v_free;
  integrate(m.model, d.q_m, 0.5 * m.settings.h * d.v, d.q, m.threads);
  normalizeConfiguration(m.model, d.q, m.threads);
  d.t += m.settings.h;
  d.stats.t = d.t;
  d.stats.t_update = seconds(start);
}

void diagnose(const StepModel& m, StepData& d) {
  forwardKinematics(m.model, d.model_data, d.q, d.v);
  d.stats.kinetic = kineticEnergy(m.model, d.model_data);
  d.stats.potential = potentialEnergy(m.model, d.model_data);
  evaluateContactGaps(m.model, d.model_data, m.cmodel, d.contact_data, d.t, d.end_gap);
  struct Penetration {
    double max = 0.0, sum = 0.0;
    long count = 0;
    void add(double g) {
      if (!(g < 0.0)) return;
      max = std::max(max, -g);
      sum += -g;
      ++count;
    }
  };
  Penetration total = reduceInChunks(
      static_cast<long>(d.end_gap.size()), m.threads, Penetration{},
      [&](long c, Penetration& part) { part.add(d.end_gap[c]); },
      [](Penetration& sum, const Penetration& part) {
        sum.max = std::max(sum.max, part.max);
        sum.sum += part.sum;
        sum.count += part.count;
      });
  for (const ConstraintFunction& f : m.model.constraints) total.add(f.gap(d.q));
  d.stats.penetration_max = total.max;
  d.stats.penetration_sum = total.sum;
  d.stats.penetration_count = static_cast<int>(total.count);
}

}  // namespace stepping
}  // namespace sweep
