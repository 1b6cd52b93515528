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
#include "integrators/step_data.hpp"

namespace sweep {

class TimeStepper {
 public:
  TimeStepper(const Model& model, const ContactModel& cmodel, const SchemeSettings& settings,
              AppliedForces forces = {});

  void reset(double t, const VectorX& q, const VectorX& v);
  const StepStats& step();

  // detection.verify_margin: detections per step after the first, at most; a step whose end
  // velocities still outrun the margin is flagged (StepStats::margin_outrun)
  static constexpr int kMaxRedetections = 2;

  double time() const { return d_.t; }
  const VectorX& q() const { return d_.q; }
  const VectorX& v() const { return d_.v; }
  const StepStats& stats() const { return d_.stats; }
  const SchemeSettings& settings() const { return m_.settings; }
  const ContactData& contactData() const { return d_.contact_data; }
  const ContactProblem& problem() const { return d_.problem; }  // of the last step's solve
  // impulse (normal, tangents) of each contact of contactData().contacts in the last step
  const std::vector<Vector3>& impulses() const { return d_.impulse; }
  // rolling torque impulse of each contact in the last step (tangent axes; 2D: z), empty
  // when no law has rolling resistance
  const std::vector<Vector2>& rollingImpulses() const { return d_.rolling; }
  // impulse of each joint limit (Model::limits) in the last step
  const std::vector<double>& limitImpulses() const { return d_.limit_impulse; }
  // impulse (normal, tangents) of each constraint by functions (Model::constraints)
  const std::vector<Vector3>& constraintImpulses() const { return d_.constraint_impulse; }
  double energy();  // kinetic + potential at the current state
  // a command to actuator a (Model::actuators), held until the next; its NaN entries leave the
  // actuator's own tables in force (integrators/actuation.hpp)
  void command(int actuator, ActuatorCommand command) {
    command.time = d_.t;
    d_.actuator_command.at(static_cast<std::size_t>(actuator)) = command;
  }
  // the torque (force) each actuator applied over the last step
  const std::vector<double>& actuatorTorques() const { return d_.actuator_torque; }
  // each servo's target position at the last step's end (NaN: none), and whether the last step
  // held the actuator at its torque limit
  const std::vector<double>& actuatorTargets() const { return d_.actuator_target; }
  const std::vector<char>& actuatorsSaturated() const { return d_.actuator_saturated; }
  const StepModel& stepModel() const { return m_; }
  const StepData& data() const { return d_; }  // everything the last step computed

 private:
  StepModel m_;
  StepData d_;
};

}  // namespace sweep
