#pragma once
// Convergence studies of the validation cases against their references (issue #7,
// docs/validation.md): the error of each scheme's trajectory as h is halved, and the
// observed order. Shared by the tests and bench/validation_convergence.
#include <functional>
#include <vector>

#include "apps/sweep/scene_file.hpp"

#include "integrators/event_driven.hpp"
#include "integrators/time_stepper.hpp"
#include "models/archetypes.hpp"

namespace sweep {

struct ConvergencePoint {
  double h = 0.0;
  double error = 0.0;  // the case's error measure at this h
  double order = 0.0;  // log2(error(2h) / error(h)); 0 for the coarsest h
};

// error(h) for each h, with the local orders log2(error(2h) / error(h)).
std::vector<ConvergencePoint> convergenceStudy(const std::vector<double>& steps,
                                               const std::function<double(double h)>& error);

// Least-squares slope of log2(error) against log2(h): the observed order over all points.
// The local orders of an impact problem scatter (where an impact falls inside a step
// changes the error by up to a step's worth), so the fit is the number to judge.
double fittedOrder(const std::vector<ConvergencePoint>& points);

// V1: the RMS of z_h(t) - z_ref(t), the ball's centre height, over the sample times
// 0 < t = j * sample_interval <= t_end, against the event-driven CVODE reference (root finding on
// the gap, Newton's law at each impact). Every h must divide sample_interval.
std::vector<ConvergencePoint> bouncingBallConvergence(const BouncingBallParameters& parameters,
                                                      Scheme scheme,
                                                      const std::vector<double>& steps,
                                                      double t_end, double sample_interval);

// V1's floor as the event-driven reference's constraint: gap q_z - r, normal e_z.
std::vector<UnilateralConstraint> bouncingBallConstraints(const BouncingBallParameters& parameters);

// The event-driven reference's impact times of V1 up to t_end.
std::vector<double> bouncingBallReferenceImpacts(const BouncingBallParameters& parameters,
                                                 double t_end);

// V5: omega+ / omega- at the first corner impact of the rocking block (the first step whose
// angular speed drops below 0.8 of the previous one, once above 0.05 rad/s), and how far the
// impacting corner slid during that step (m). NaN ratio if no impact within 40 000 steps.
struct RockingImpact {
  double ratio = 0.0;
  double corner_slip = 0.0;
};
RockingImpact rockingBlockFirstImpact(const RockingBlockParameters& parameters, Scheme scheme,
                                      double h, int threshold_updates = 0);

// V10: the event-driven reference of the wall pendulum (its constraints, in absolute angles
// th1 = q1, th2 = q1 + q2), sampled at j * sample_interval up to t_end: joint angles per
// sample, and the impacts and persistent-contact phases it went through.
struct WallPendulumReference {
  std::vector<VectorX> q, v;  // samples j = 0 .. t_end / sample_interval
  std::vector<Impact> impacts;
  std::vector<ContactPhase> phases;
  double energy_start = 0.0, energy_end = 0.0;
};
WallPendulumReference wallPendulumReference(const WallPendulumParameters& parameters, double t_end,
                                            double sample_interval);

// V10: the RMS over the samples of the joint-angle error |q_h(t) - q_ref(t)| (rad), for each h.
std::vector<ConvergencePoint> wallPendulumConvergence(const WallPendulumParameters& parameters,
                                                      Scheme scheme,
                                                      const std::vector<double>& steps,
                                                      double t_end, double sample_interval);

// V3 from a scene file like examples/archetypes/ramp_force.yaml (a block pushed by
// F = k t along x, friction mu, mass m): |x_h(t_end) - x(t_end)| against the exact
// x(t) = k (t - t*)^3 / (6 m), t* = mu m g / k. First order: the onset is quantized to a
// step.
std::vector<ConvergencePoint> rampForceConvergence(const SceneFile& file, Scheme scheme,
                                                   const std::vector<double>& steps, double k,
                                                   double mu, double mass);

// V5: |omega+ / omega- - (1 - 3/2 sin^2 s)| at the first corner impact of the rocking block.
std::vector<ConvergencePoint> rockingBlockConvergence(const RockingBlockParameters& parameters,
                                                      Scheme scheme,
                                                      const std::vector<double>& steps);

// V7 from examples/archetypes/painleve_rod.yaml, Jean-Moreau only: the jam impulse of the
// first step, |(P_N, |P_T|) - (0.3, 0.4)|, against its h -> 0 limit (gravity adds O(h)).
std::vector<ConvergencePoint> painleveJamConvergence(const SceneFile& file,
                                                     const std::vector<double>& steps);

// V11: one run of the slider-crank with clearance to t_end: the absolute angles at the end,
// the energy (start, end, highest along the way), the work of the contact impulses summed
// over the steps (reference 5.3: it balances the energy change up to O(h)), and what the
// solver went through.
struct SliderCrankRun {
  Vector3 theta = Vector3::Zero();
  double energy_start = 0.0, energy_end = 0.0, energy_highest = 0.0;
  double contact_work = 0.0;
  long contact_steps = 0, cap_hits = 0;
  double penetration_max = 0.0;
};
SliderCrankRun sliderCrankRun(const SliderCrankParameters& parameters, Scheme scheme, double h,
                              double t_end);

// V9: one run of the woodpecker toy to t_end: the beak impacts (time and height y of the
// sleeve, one per cycle: impacts closer than 5 ms to the previous one belong to it), the
// final y, and the energy account (kinetic + gravity + spring): its start and end, its
// largest rise over one step, and the work of the contact impulses summed over the steps.
struct WoodpeckerRun {
  std::vector<double> beak_times, beak_heights;
  double y_end = 0.0;
  double energy_start = 0.0, energy_end = 0.0, largest_step_rise = 0.0;
  double contact_work = 0.0;
  long cap_hits = 0;
};
// threshold_updates: FrictionStageOptions::threshold_updates of the staggered scheme
WoodpeckerRun woodpeckerRun(const WoodpeckerParameters& parameters, Scheme scheme, double h,
                            double t_end, int threshold_updates = 0);

}  // namespace sweep
