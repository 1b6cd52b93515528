#include "integrators/time_stepper.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
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
#include "integrators/rows.hpp"
#include "integrators/screening.hpp"

namespace sweep {

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

TimeStepper::TimeStepper(const Model& model, const ContactModel& cmodel,
                         const SchemeSettings& settings, AppliedForces forces)
    : model_(model),
      cmodel_(cmodel),
      settings_(settings),
      forces_(std::move(forces)),
      data_(model),
      cdata_(model, cmodel),
      problem_ws_(model),
      q_(model.neutralConfiguration()),
      v_(VectorX::Zero(model.nv)),
      q_m_(q_),
      v_free_(v_),
      tau_(VectorX::Zero(model.nv)) {
  settings_.validate();
  for (const ConstraintFunction& f : model_.constraints) {
    if (cmodel_.dimension == 3 && f.friction > 0.0 && !f.tangent2)
      throw InputError("constraint '" + f.name +
                       "': friction in a 3D problem needs a second tangent function");
    constraint_friction_ = constraint_friction_ || f.friction > 0.0;
  }
  settings_.coulomb.threads = settings_.normal_stage.threads = settings_.friction_stage.threads =
      settings_.threadCount();
  problem_.compact_spheres = settings_.compactSphereRows();
  problem_.pack_body_form = problem_.pack_rows = settings_.packed_rows;
}

void TimeStepper::reset(double t, const VectorX& q, const VectorX& v) {
  if (q.size() != model_.nq || v.size() != model_.nv || !q.allFinite() || !v.allFinite())
    throw InputError("initial state: q must have " + std::to_string(model_.nq) + " and v " +
                     std::to_string(model_.nv) + " finite entries");
  t_ = t;
  q_ = q;
  v_ = v;
  stats_ = StepStats{};
  stats_.t = t;
  impulse_.clear();
  previous_impulse_.clear();
  staged_.clear();
  previous_staged_.clear();
  rolling_.clear();
  previous_rolling_.clear();
  limit_impulse_.assign(model_.limits.size(), 0.0);
  constraint_impulse_.assign(model_.constraints.size(), Vector3::Zero());
  // rows of the model itself, joint limits then constraints by functions, in the index space
  // of ContactProblem::contact (-1 - m)
  limit_staged_.assign(model_.limits.size() + model_.constraints.size(), StagedImpulse{});
  contact_dv_.setZero(model_.nv);
  cdata_ = ContactData(model_, cmodel_);
}

double TimeStepper::energy() {
  forwardKinematics(model_, data_, q_, v_);
  return kineticEnergy(model_, data_) + potentialEnergy(model_, data_);
}

const StepStats& TimeStepper::step() {
  stats_.step += 1;
  data_.threads = settings_.threadCount();
  midpoint();      // 1
  detect();        // 2
  freeVelocity();  // 4 (M(q_m) is factored here; stage 3 needs it)
  if (cmodel_.settings.verify_margin && settings_.normal_law != NormalLaw::Vel) {
    contact_dv_start_ = contact_dv_;
    limit_impulse_start_ = limit_impulse_;
    constraint_impulse_start_ = constraint_impulse_;
    limit_staged_start_ = limit_staged_;
  }
  assemble();  // 3
  solve();     // 5
  stats_.redetections = 0;
  stats_.margin_outrun = false;
  // VEL solves the closed contacts only, which the margin does not decide
  if (cmodel_.settings.verify_margin && settings_.normal_law != NormalLaw::Vel) {
    for (DetectionMargins needed = marginNeeded(); needed.balls > 0.0 || needed.others > 0.0;
         needed = marginNeeded()) {
      if (stats_.redetections == kMaxRedetections) {
        stats_.margin_outrun = true;
        break;
      }
      ++stats_.redetections;
      redoStep(needed);
    }
  }
  update();  // 6
  diagnose();
  // periodic boundaries: bodies that left the cell re-enter at the other side; after the
  // diagnostics, which evaluate the gaps of this step's contacts on this step's images
  wrapPeriodic(cmodel_, q_);
  return stats_;
}

void TimeStepper::midpoint() {
  integrate(model_, q_, 0.5 * settings_.h * v_, q_m_, settings_.threadCount());
}

void TimeStepper::detect(const DetectionMargins& at_least) {
  const auto start = Clock::now();
  const double t_m = t_ + 0.5 * settings_.h;
  forwardKinematics(model_, data_, q_m_, v_);
  DetectionMargins margins = detectionMargins(model_, data_, cmodel_, settings_.h, t_m);
  margins.others = std::max(margins.others, at_least.others);
  margins.balls = std::max(margins.balls, at_least.balls);
  stats_.margin = margins.others;
  stats_.margin_balls = margins.balls;
  detectContacts(model_, data_, cmodel_, cdata_, t_m, margins, settings_.threadCount());
  std::swap(impulse_, previous_impulse_);
  impulse_.assign(cdata_.contacts.size(), Vector3::Zero());
  std::swap(staged_, previous_staged_);
  staged_.assign(cdata_.contacts.size(), StagedImpulse{});
  if (cmodel_.rolling) {
    std::swap(rolling_, previous_rolling_);
    rolling_.assign(cdata_.contacts.size(), Vector2::Zero());
  }
  solved_.assign(cdata_.contacts.size(), 0);
  stats_.candidates = static_cast<int>(cdata_.contacts.size());
  stats_.t_detect = seconds(start);
}

DetectionMargins TimeStepper::marginNeeded() {
  // A pair left out had gap >= margin at q_m and moves by h/2 times its relative velocity
  // until q_{k+1}: at most h/2 (e_a + e_b) <= h * (fastest end speed of a shape point), and
  // for two balls at most h * ballClosingSpeed at the end velocities.
  const double t_m = t_ + 0.5 * settings_.h;
  forwardKinematics(model_, data_, q_m_, v_free_);
  // a state that stopped being finite is the run's to report, not a reason to detect again;
  // else the default rule (twice the speed) on the end velocities: one more detection, mostly
  auto needed = [&](double reach, double margin) {
    if (!std::isfinite(reach) || reach <= margin) return 0.0;
    return 2.0 * reach + cmodel_.margin_floor;
  };
  DetectionMargins out;
  out.others = needed(settings_.h * fastestShapeSpeed(model_, data_, cmodel_, t_m), stats_.margin);
  out.balls = cmodel_.settings.margin_rule == MarginRule::Relative
                  ? needed(settings_.h * ballClosingSpeed(model_, data_, cmodel_, t_m),
                           stats_.margin_balls)
                  : out.others;  // one margin for every pair
  return out;
}

void TimeStepper::redoStep(const DetectionMargins& margins) {
  // back to the state after midpoint(): the detection swaps its lists and the warm starts
  // with the previous step's, so swap them back first (the solve's results are discarded)
  std::swap(cdata_.contacts, cdata_.previous);
  std::swap(impulse_, previous_impulse_);
  std::swap(staged_, previous_staged_);
  if (cmodel_.rolling) std::swap(rolling_, previous_rolling_);
  contact_dv_ = contact_dv_start_;
  limit_impulse_ = limit_impulse_start_;
  constraint_impulse_ = constraint_impulse_start_;
  limit_staged_ = limit_staged_start_;
  // the step's cost counts every solve; its other figures are those of the last
  const StepStats before = stats_;
  detect(margins);
  freeVelocity();
  assemble();
  solve();
  stats_.t_detect += before.t_detect;
  stats_.t_assemble += before.t_assemble;
  stats_.t_solve += before.t_solve;
  stats_.updates += before.updates;
  stats_.solves += before.solves;
  stats_.iterations_stage1 += before.iterations_stage1;
  stats_.iterations_stage2 += before.iterations_stage2;
}

void TimeStepper::addSystemForces(double t, const VectorX& q, const VectorX& v) {
  for (const Component& c : model_.components) {
    if (c.system < 0 || !model_.systems[c.system].forces) continue;
    const EquationSystem& system = model_.systems[c.system];
    const VectorX f = system.forces(t, q.segment(c.q_index, c.nq), v.segment(c.v_index, c.nv));
    if (f.size() != c.nv || !f.allFinite())
      throw std::runtime_error("system '" + system.name + "': its forces must be " +
                               std::to_string(c.nv) + " finite values at t = " + std::to_string(t));
    tau_.segment(c.v_index, c.nv) += f;
  }
}

void TimeStepper::freeVelocity() {
  const auto start = Clock::now();
  const double t_m = t_ + 0.5 * settings_.h;
  tau_.setZero();
  if (forces_) forces_(t_m, q_m_, v_, tau_);
  addSystemForces(t_m, q_m_, v_);
  // detect() left the kinematics of data at (q_m, v); constant mass blocks (particles) are
  // skipped, the others rebuilt and factored
  v_free_ = v_ + settings_.h * forwardDynamicsFromKinematics(model_, data_, v_, tau_);
  stats_.t_assemble = seconds(start);
}

void TimeStepper::assembleJacobian() {
  const auto start = Clock::now();
  // forwardDynamics left the kinematics of data at q_m
  // VEL solves closed contacts only: the open candidates need no rows
  const double max_gap = settings_.normal_law == NormalLaw::Vel
                             ? touchingGap(cmodel_)
                             : std::numeric_limits<double>::infinity();
  // rows the problem writes in body form from the contacts need no Jacobian rows: free
  // particles, the bulk of a granular step (contact_problem.hpp, rowInBodyForm)
  const int m = static_cast<int>(cdata_.contacts.size());
  jacobian_skip_.resize(m);
  if (cmodel_.dimension == 3) findFreeParticles(model_, data_, cmodel_, problem_ws_);
  const int threads = settings_.threadCount();
#pragma omp parallel for schedule(static) num_threads(threads) if (m >= kParallelItems)
  for (int id = 0; id < m; ++id)
    jacobian_skip_[id] = (!unassembled_.empty() && unassembled_[id]) ||
                         (problem_.pack_body_form &&
                          rowInBodyForm(model_, data_, cmodel_, cdata_.contacts[id], problem_ws_));
  assembleContactJacobian(model_, data_, cmodel_, cdata_, t_ + 0.5 * settings_.h, max_gap,
                          &jacobian_skip_);
  jacobian_stale_ = false;
  stats_.t_assemble += seconds(start);
}

void TimeStepper::assemble() {
  const auto start = Clock::now();
  const double t_m = t_ + 0.5 * settings_.h;
  if (!settings_.screening) {
    deferred_.clear();
    unassembled_.clear();
    assembleJacobian();
    assembleProblem();
    return;
  }
  // Round one leaves out the candidates that did not carry an impulse at the last step, are
  // farther than `near`, and are not predicted to break their law at the velocity of the
  // step's start, the contact-free one or the contact-free one plus the last step's contact
  // push. A powder heap under IQS at h = 1e-4 has 7 to 10 candidates per closed contact; of
  // the candidates the solve then admits, 99 % are within 1.5 um. `near` defaults to twice
  // that, a fifth of the smallest radius: one solve per step on the 35 000-sphere bed instead
  // of two (docs/powder_bed.md).
  const int m = static_cast<int>(cdata_.contacts.size());
  const double tau = 0.5 * settings_.h, slack = cmodel_.margin_floor;
  const double touching = touchingGap(cmodel_);
  const double factor = cmodel_.settings.speed_factor;
  const double near =
      settings_.screening_gap >= 0.0 ? settings_.screening_gap : 200.0 * cmodel_.margin_floor;
  deferred_.assign(m, 0);
  unassembled_.assign(m, 0);
  screening_bias_.resize(m);
  if (contact_dv_.size() != model_.nv) contact_dv_ = VectorX::Zero(model_.nv);
  v_predicted_ = v_free_ + contact_dv_;  // the last step's contact push, repeated
  // Candidates between free bodies (and walls, driven bodies) are judged from their bodies'
  // twists, and the ones left out get no Jacobian rows: on the 35 000-sphere bed the rows of
  // half a million candidates cost a quarter of the step, in memory traffic alone.
  const int threads = settings_.threadCount();
  rootBodyTwists(model_, data_, v_, start_twist_, threads);
  rootBodyTwists(model_, data_, v_free_, free_twist_, threads);
  rootBodyTwists(model_, data_, v_predicted_, end_twist_, threads);
  auto carriedImpulse = [&](const Contact& contact) {
    const int previous = contact.previous;
    return previous >= 0 && previous < static_cast<int>(previous_impulse_.size()) &&
           previous_impulse_[previous].x() > 0.0;
  };
  auto leaveOut = [&](const Contact& contact, double u_start, double u_free, double u_pushed,
                      double& bias) {
    bias = normalBias(settings_.normal_law, contact.restitution, u_start, contact.gap, tau);
    return tau * (bias + factor * std::min({u_start, u_free, u_pushed, 0.0})) > slack;
  };
#pragma omp parallel for schedule(static) num_threads(threads) if (m >= kParallelItems)
  for (int id = 0; id < m; ++id) {
    const Contact& contact = cdata_.contacts[id];
    if (settings_.normal_law == NormalLaw::Vel || contact.gap <= near || carriedImpulse(contact))
      continue;
    std::array<double, 3> u;  // at the start, contact-free, contact-free plus the last push
    if (!normalVelocitiesFromTwists<3>(model_, data_, contact,
                                       {&start_twist_, &free_twist_, &end_twist_}, t_m, u))
      continue;
    if (leaveOut(contact, u[0], u[1], u[2], screening_bias_[id]))
      unassembled_[id] = deferred_[id] = 1;
  }
  stats_.t_assemble += seconds(start);
  assembleJacobian();
  // contacts with a link of a tree, from their Jacobian rows
  const ContactJacobian& J = cdata_.jacobian;
#pragma omp parallel for schedule(static) num_threads(threads) if (m >= kParallelItems)
  for (int id = 0; id < m; ++id) {
    const Contact& contact = cdata_.contacts[id];
    if (betweenRoots(model_, contact)) continue;
    if (settings_.normal_law == NormalLaw::Vel && contact.gap > touching) continue;
    if (contact.gap <= near || carriedImpulse(contact)) continue;
    deferred_[id] =
        leaveOut(contact, J.relativeVelocity(id, v_).x(), J.relativeVelocity(id, v_free_).x(),
                 J.relativeVelocity(id, v_predicted_).x(), screening_bias_[id]);
  }
  assembleProblem();
}

void TimeStepper::assembleProblem() {
  const auto start = Clock::now();
  assembleContactProblem(model_, data_, cmodel_, cdata_, t_ + 0.5 * settings_.h,
                         settings_.normal_law, 0.5 * settings_.h, q_m_, v_, problem_, problem_ws_,
                         &v_free_, deferred_.empty() ? nullptr : &deferred_,
                         settings_.threadCount());
  const int n = problem_.size();
  stats_.active = n;
  stats_.islands = problem_.islandCount();
  nlgs_ws_.prepare(n, model_.nv, static_cast<int>(model_.components.size()));
  // warm start from this step's last solve, or else the previous step's impulses of the same
  // contacts
  P_.assign(n, Vector3::Zero());
  R_.assign(problem_.rolling ? n : 0, Vector2::Zero());
#pragma omp parallel for schedule(static) \
    num_threads(settings_.threadCount()) if (n >= kParallelItems)
  for (int c = 0; c < n; ++c) {
    const int id = problem_.contact[c];
    if (id < 0) {
      const int m = -1 - id, limits = static_cast<int>(model_.limits.size());
      if (m < limits)
        P_[c].x() = limit_impulse_[m];
      else
        P_[c] = constraint_impulse_[m - limits];
      continue;
    }
    if (solved_[id]) {
      P_[c] = impulse_[id];
      if (problem_.rolling) R_[c] = rolling_[id];
      continue;
    }
    const int previous = cdata_.contacts[id].previous;
    if (previous >= 0 && previous < static_cast<int>(previous_impulse_.size()))
      P_[c] = previous_impulse_[previous];
    if (problem_.rolling && previous >= 0 && previous < static_cast<int>(previous_rolling_.size()))
      R_[c] = previous_rolling_[previous];
  }
  stats_.t_assemble += seconds(start);
}

void TimeStepper::update() {
  const auto start = Clock::now();
  const int n = problem_.size();
  // contact work with the local velocities of H(q_m) at the start and end of the step
  stats_.work_normal = stats_.work_tangent = 0.0;
  // packed 3D rows (scheme A's powder rows): one pass for U and U_r, the generic reads' sums
  // to the bit (rows without a rolling row carry R = 0)
  const RowReader rows(problem_, RowReader::kPacked3d | RowReader::kSpheres3d);
  auto velocities = [&](int c, const VectorX& v, Vector3& u, Vector2& u_rolling) {
    rows.visit(c, [&](const auto& row) { row.velocity(v, u, u_rolling); });
  };
  // {normal, tangential} work, summed in chunks of rows: the same bits on any thread count
  using Work = std::array<double, 2>;
  const Work work = reduceInChunks(
      n, settings_.threadCount(), Work{0.0, 0.0},
      [&](long c, Work& sum) {
        Vector3 u_end, u_start;
        Vector2 rolling_end = Vector2::Zero(), rolling_start = Vector2::Zero();
        velocities(c, v_free_, u_end, rolling_end);
        const Vector3 u_mean = 0.5 * (problem_.velocity_start[c] + u_end);
        sum[0] += P_[c].x() * u_mean.x();
        sum[1] += P_[c].tail<2>().dot(u_mean.tail<2>());
        if (problem_.contact[c] >= 0 && problem_.rolling) {
          velocities(c, v_, u_start, rolling_start);
          sum[1] += R_[c].dot(0.5 * (rolling_start + rolling_end));
        }
      },
      [](Work& total, const Work& part) {
        total[0] += part[0];
        total[1] += part[1];
      });
  stats_.work_normal = work[0];
  stats_.work_tangent = work[1];
  v_ = v_free_;
  integrate(model_, q_m_, 0.5 * settings_.h * v_, q_, settings_.threadCount());
  normalizeConfiguration(model_, q_, settings_.threadCount());
  t_ += settings_.h;
  stats_.t = t_;
  stats_.t_update = seconds(start);
}

void TimeStepper::diagnose() {
  forwardKinematics(model_, data_, q_, v_);
  stats_.kinetic = kineticEnergy(model_, data_);
  stats_.potential = potentialEnergy(model_, data_);
  evaluateContactGaps(model_, data_, cmodel_, cdata_, t_, end_gap_);
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
      static_cast<long>(end_gap_.size()), settings_.threadCount(), Penetration{},
      [&](long c, Penetration& part) { part.add(end_gap_[c]); },
      [](Penetration& sum, const Penetration& part) {
        sum.max = std::max(sum.max, part.max);
        sum.sum += part.sum;
        sum.count += part.count;
      });
  for (const ConstraintFunction& f : model_.constraints) total.add(f.gap(q_));
  stats_.penetration_max = total.max;
  stats_.penetration_sum = total.sum;
  stats_.penetration_count = static_cast<int>(total.count);
}

}  // namespace sweep
