// What the ranks of a distributed step report together (integrators/distributed_stepper.hpp): a
// failure found on one rank raised on all, the step's statistics reduced over the ranks in rank
// order (the same bits on every rank), and the state and contacts gathered for rank 0's files.
#include <algorithm>
#include <string>

#include "framework/energy.hpp"
#include "framework/error.hpp"
#include "integrators/distributed_stepper.hpp"

namespace sweep {

void DistributedStepper::findFailure() {
  failure_.clear();
  runaway_ = false;
  try {
    stepping::checkRunaway(m_, d_);
  } catch (const RunawayError& e) {
    failure_ = e.what();
    runaway_ = true;
    return;
  }
  for (int i = 0; i < owned_.size(); ++i) {
    const Body& body = m_.model.bodies[owned_.id[i]];
    if (d_.q.segment(body.q_index, nq_).allFinite() && d_.v.segment(body.v_index, nv_).allFinite())
      continue;
    failure_ = "step " + std::to_string(d_.stats.step) + " (t = " + formatValue(d_.t) +
               "): the state is no longer finite (body '" + body.name + "')";
    return;
  }
}

void DistributedStepper::ownedEnergies(double& kinetic, double& potential) const {
  kinetic = potential = 0.0;
  if (!failure_.empty()) return;
  // diagnose's kinematics at q_{k+1}, read for the bodies this rank answers for: its grains,
  // and on rank 0 every body that is not one (walls, plates, driven shapes)
  const Data& data = d_.model_data;
  auto add = [&](int b) {
    const Inertia& inertia = m_.model.bodies[b].inertia;
    kinetic += 0.5 * data.velocity[b].dot(inertia.apply(data.velocity[b]));
    potential -= inertia.mass * m_.model.gravity.dot(data.world_pose[b].apply(inertia.com));
  };
  for (int i = 0; i < owned_.size(); ++i) add(static_cast<int>(owned_.id[i]));
  if (ranks_.rank() == 0)
    for (int b = 0; b < static_cast<int>(m_.model.bodies.size()); ++b)
      if (!is_particle_[b]) add(b);
}

void DistributedStepper::reduceStats() {
  // summed in rank order from a gather: the same bits on every rank and every repeat
  double kinetic = 0.0, potential = 0.0;
  ownedEnergies(kinetic, potential);
  const StepStats& s = d_.stats;
  const double failure = failure_.empty() ? 0.0 : (runaway_ ? 2.0 : 1.0);
  const std::vector<double> mine{static_cast<double>(d_.problem.size()),
                                 static_cast<double>(s.iterations_stage1),
                                 s.cap_hit ? 1.0 : 0.0,
                                 s.residual,
                                 kinetic,
                                 static_cast<double>(bytes_),
                                 static_cast<double>(shared_count_),
                                 static_cast<double>(owned_.size()),
                                 s.status == SolverStatus::Failed ? 1.0 : 0.0,
                                 static_cast<double>(s.candidates),
                                 static_cast<double>(s.islands),
                                 static_cast<double>(s.updates),
                                 static_cast<double>(s.local_failures),
                                 s.penetration_max,
                                 s.penetration_sum,
                                 static_cast<double>(s.penetration_count),
                                 potential,
                                 s.work_normal,
                                 s.work_tangent,
                                 failure,
                                 static_cast<double>(s.deferred),
                                 static_cast<double>(s.unassembled),
                                 static_cast<double>(carried_),
                                 static_cast<double>(handed_over_),
                                 static_cast<double>(s.iterations_stage2)};
  ranks_.gatherEqual(mine, reduce_all_);
  const std::vector<double>& all = reduce_all_;
  const std::size_t width = mine.size();
  double active = 0.0, iterations = 0.0, cap = 0.0, residual = 0.0, energy = 0.0, bytes = 0.0,
         shared = 0.0, most = 0.0, failed = 0.0, candidates = 0.0, islands = 0.0, updates = 0.0,
         local_failures = 0.0, penetration_max = 0.0, penetration_sum = 0.0,
         penetration_count = 0.0, potential_sum = 0.0, work_normal = 0.0, work_tangent = 0.0,
         deferred = 0.0, unassembled = 0.0, carried = 0.0, handed_over = 0.0, iterations2 = 0.0;
  int failing_rank = -1;
  bool runaway = false;
  for (std::size_t r = 0; r * width < all.size(); ++r) {
    const double* x = all.data() + r * width;
    active += x[0];
    iterations = std::max(iterations, x[1]);
    cap = std::max(cap, x[2]);
    residual = std::max(residual, x[3]);
    energy += x[4];
    bytes += x[5];
    shared += x[6];
    most = std::max(most, x[7]);
    failed = std::max(failed, x[8]);
    candidates += x[9];
    islands += x[10];
    updates += x[11];
    local_failures += x[12];
    penetration_max = std::max(penetration_max, x[13]);
    penetration_sum += x[14];
    penetration_count += x[15];
    potential_sum += x[16];
    work_normal += x[17];
    work_tangent += x[18];
    if (x[19] > 0.0 && failing_rank < 0) {
      failing_rank = static_cast<int>(r);
      runaway = x[19] > 1.0;
    }
    deferred += x[20];
    unassembled += x[21];
    carried += x[22];
    handed_over += x[23];
    iterations2 = std::max(iterations2, x[24]);
  }
  // a runaway or a state no longer finite on any rank ends the step on every rank, with the
  // lowest such rank's message
  if (failing_rank >= 0) {
    std::string message = failure_;
    ranks_.broadcast(message, failing_rank);
    if (runaway) throw RunawayError(message);
    throw CollectiveError(message);
  }
  d_.stats.active = static_cast<int>(active);
  d_.stats.iterations_stage1 = static_cast<int>(iterations);
  d_.stats.iterations_stage2 = static_cast<int>(iterations2);
  d_.stats.cap_hit = cap > 0.0;
  d_.stats.residual = residual;
  d_.stats.kinetic = energy;
  d_.stats.potential = potential_sum;
  d_.stats.candidates = static_cast<int>(candidates);
  d_.stats.islands = static_cast<int>(islands);
  d_.stats.updates = static_cast<long>(updates);
  d_.stats.local_failures = static_cast<int>(local_failures);
  d_.stats.penetration_max = penetration_max;
  d_.stats.penetration_sum = penetration_sum;
  d_.stats.penetration_count = static_cast<int>(penetration_count);
  d_.stats.work_normal = work_normal;
  d_.stats.work_tangent = work_tangent;
  d_.stats.deferred = static_cast<int>(deferred);
  d_.stats.unassembled = static_cast<int>(unassembled);
  if (failed > 0.0) d_.stats.status = SolverStatus::Failed;
  dstats_.bytes_sent = static_cast<std::int64_t>(bytes);
  dstats_.shared_bodies = static_cast<std::int64_t>(shared);
  dstats_.carried = static_cast<std::int64_t>(carried);
  dstats_.handed_over = static_cast<std::int64_t>(handed_over);
  dstats_.imbalance =
      most * ranks_.size() / std::max(1.0, static_cast<double>(particle_body_.size()));
}

void DistributedStepper::gatherState(VectorX& q, VectorX& v) const {
  std::vector<double> mine;
  for (int i = 0; i < owned_.size(); ++i) {
    const Body& body = m_.model.bodies[owned_.id[i]];
    mine.push_back(static_cast<double>(owned_.id[i]));
    for (int k = 0; k < nq_; ++k) mine.push_back(d_.q[body.q_index + k]);
    for (int k = 0; k < nv_; ++k) mine.push_back(d_.v[body.v_index + k]);
  }
  const std::vector<double> all = ranks_.gather(mine);
  q = d_.q;
  v = d_.v;
  const std::size_t width = 1 + nq_ + nv_;
  for (std::size_t i = 0; i + width <= all.size(); i += width) {
    const Body& body = m_.model.bodies[static_cast<int>(all[i])];
    for (int k = 0; k < nq_; ++k) q[body.q_index + k] = all[i + 1 + k];
    for (int k = 0; k < nv_; ++k) v[body.v_index + k] = all[i + 1 + nq_ + k];
  }
}

void DistributedStepper::gatherContacts(std::vector<Contact>& contacts,
                                        std::vector<Vector3>& impulses) const {
  // per contact: the two bodies (kind, index), the gap, normal, tangents, witness points,
  // friction, restitution, rolling, and the impulse
  constexpr int kWidth = 26;
  const auto& mine = d_.contact_data.contacts;
  std::vector<double> packed;
  packed.reserve(mine.size() * kWidth);
  for (std::size_t c = 0; c < mine.size(); ++c) {
    const Contact& k = mine[c];
    const Vector3 P = c < d_.impulse.size() ? d_.impulse[c] : Vector3::Zero();
    packed.insert(packed.end(),
                  {static_cast<double>(k.body_a.kind), static_cast<double>(k.body_a.index),
                   static_cast<double>(k.body_b.kind), static_cast<double>(k.body_b.index), k.gap});
    for (const Vector3* x : {&k.normal, &k.tangent1, &k.tangent2, &k.point_a, &k.point_b, &P})
      packed.insert(packed.end(), x->data(), x->data() + 3);
    packed.insert(packed.end(), {k.friction, k.restitution, k.rolling});
  }
  std::vector<double> all;
  ranks_.gatherOnRoot(packed, all);
  contacts.clear();
  impulses.clear();
  for (std::size_t at = 0; at + kWidth <= all.size(); at += kWidth) {
    const double* x = all.data() + at;
    Contact k;
    k.body_a.kind = static_cast<BodyRef::Kind>(static_cast<int>(x[0]));
    k.body_a.index = static_cast<int>(x[1]);
    k.body_b.kind = static_cast<BodyRef::Kind>(static_cast<int>(x[2]));
    k.body_b.index = static_cast<int>(x[3]);
    k.gap = x[4];
    Vector3* fields[] = {&k.normal, &k.tangent1, &k.tangent2, &k.point_a, &k.point_b};
    for (int f = 0; f < 5; ++f) *fields[f] = Vector3(x[5 + 3 * f], x[6 + 3 * f], x[7 + 3 * f]);
    impulses.emplace_back(x[20], x[21], x[22]);
    k.friction = x[23];
    k.restitution = x[24];
    k.rolling = x[25];
    contacts.push_back(k);
  }
}

}  // namespace sweep
