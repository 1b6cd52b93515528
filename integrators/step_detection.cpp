// Stages 1 and 2 of a step (time_stepper.hpp): the midpoint q_m = q_k + h/2 v_k, the contacts
// detected there, and the check that the detection's margins covered the end velocities,
// which redoes stages 2 to 5 with wider ones where they did not.
#include <algorithm>
#include <cmath>
#include <functional>
#include <utility>

#include "framework/configuration.hpp"
#include "framework/kinematics.hpp"
#include "framework/parallel.hpp"
#include "integrators/time_stepper.hpp"

namespace sweep {
namespace stepping {

void midpoint(const StepModel& m, StepData& d) {
  integrate(m.model, d.q, 0.5 * m.settings.h * d.v, d.q_m, m.threads,
            d.model_data.componentSubset());
}

int contactOwner(const std::vector<int>& body_rank, const Contact& contact) {
  int lowest = -1;
  for (const BodyRef* body : {&contact.body_a, &contact.body_b})
    if (body->kind == BodyRef::Kind::Dynamic) {
      const int owner = body_rank[body->index];
      if (owner >= 0 && (lowest < 0 || owner < lowest)) lowest = owner;
    }
  return lowest;
}

namespace {
void keepOwnedContacts(const std::vector<int>& body_rank, int rank,
                       std::vector<Contact>& contacts) {
  contacts.erase(std::remove_if(contacts.begin(), contacts.end(),
                                [&](const Contact& contact) {
                                  return contactOwner(body_rank, contact) != rank;
                                }),
                 contacts.end());
}
}  // namespace

void detect(const StepModel& m, StepData& d, const DetectionMargins& at_least) {
  const auto start = std::chrono::steady_clock::now();
  const double t_m = d.t + 0.5 * m.settings.h;
  forwardKinematics(m.model, d.model_data, d.q_m, d.v);
  DetectionMargins margins =
      d.scene_speeds ? detectionMargins(m.cmodel, m.settings.h, d.scene_speeds())
                     : detectionMargins(m.model, d.model_data, m.cmodel, m.settings.h, t_m);
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
  d.stats.t_detect = secondsSince(start);
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
  const MarginSpeeds speeds =
      d.scene_speeds ? d.scene_speeds() : marginSpeeds(m.model, d.model_data, m.cmodel, t_m);
  DetectionMargins out;
  out.others = needed(m.settings.h * speeds.fastest_shape, d.stats.margin);
  out.balls = m.cmodel.settings.margin_rule == MarginRule::Relative
                  ? needed(m.settings.h * speeds.ballClosing(), d.stats.margin_balls)
                  : out.others;  // one margin for every pair
  return out;
}

void undoDetection(const StepModel& m, StepData& d) {
  // the detection swaps its lists and the warm starts with the previous step's
  std::swap(d.contact_data.contacts, d.contact_data.previous);
  std::swap(d.impulse, d.previous_impulse);
  std::swap(d.staged, d.previous_staged);
  if (m.cmodel.rolling) std::swap(d.rolling, d.previous_rolling);
}

void redoStep(const StepModel& m, StepData& d, const DetectionMargins& margins,
              const std::function<void(const DetectionMargins&)>& stages_2_to_5) {
  // back to the state after midpoint(m, d) (the solve's results are discarded)
  undoDetection(m, d);
  d.contact_dv = d.contact_dv_start;
  d.limit_impulse = d.limit_impulse_start;
  d.constraint_impulse = d.constraint_impulse_start;
  d.limit_staged = d.limit_staged_start;
  // the step's cost counts every solve; its other figures are those of the last
  const StepStats before = d.stats;
  if (stages_2_to_5) {
    stages_2_to_5(margins);
  } else {
    detect(m, d, margins);
    freeVelocity(m, d);
    assemble(m, d);
    solve(m, d);
  }
  d.stats.t_detect += before.t_detect;
  d.stats.t_assemble += before.t_assemble;
  d.stats.t_solve += before.t_solve;
  d.stats.updates += before.updates;
  d.stats.solves += before.solves;
  d.stats.iterations_stage1 += before.iterations_stage1;
  d.stats.iterations_stage2 += before.iterations_stage2;
}

}  // namespace stepping
}  // namespace sweep
