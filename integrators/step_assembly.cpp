// Stages 4 and 3 of a step (time_stepper.hpp): the contact-free velocity v_free at q_m, the
// contacts' Jacobian rows, the candidates that candidate screening leaves out of the first
// solve, and the contact problem with its warm start.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "contact/detection.hpp"
#include "framework/dynamics.hpp"
#include "framework/parallel.hpp"
#include "integrators/screening.hpp"
#include "integrators/time_stepper.hpp"

namespace sweep {
namespace stepping {

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
  const auto start = std::chrono::steady_clock::now();
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
  d.stats.t_assemble = secondsSince(start);
}

void assembleJacobian(const StepModel& m, StepData& d) {
  const auto start = std::chrono::steady_clock::now();
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
  d.stats.t_assemble += secondsSince(start);
}

void assemble(const StepModel& m, StepData& d) {
  const auto start = std::chrono::steady_clock::now();
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
  // of two (docs/powder_bed.md). A grain a driven body strikes takes up the body's speed within
  // the step and closes on the neighbours within that speed times h/2, so `near` is at least
  // that reach: a blade at 0.1 m/s strikes a few grains every step, and without it the
  // staggered scheme's powder job solved 1.34 times a step instead of 1.06.
  const int contacts = static_cast<int>(d.contact_data.contacts.size());
  const double tau = 0.5 * m.settings.h, slack = m.cmodel.margin_floor;
  const double factor = m.cmodel.settings.speed_factor;
  const double near =
      m.settings.screening_gap >= 0.0
          ? m.settings.screening_gap
          : std::max(200.0 * m.cmodel.margin_floor,
                     factor * tau * fastestDrivenShapeSpeed(m.model, m.cmodel, t_m));
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
  d.stats.t_assemble += secondsSince(start);
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
  const auto start = std::chrono::steady_clock::now();
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
  d.stats.t_assemble += secondsSince(start);
}

}  // namespace stepping
}  // namespace sweep
