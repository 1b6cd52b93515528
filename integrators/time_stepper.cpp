#include "integrators/time_stepper.hpp"

#include <algorithm>
#include <array>
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

}  // namespace stepping
}  // namespace sweep
