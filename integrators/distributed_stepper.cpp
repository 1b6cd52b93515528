#include "integrators/distributed_stepper.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "framework/error.hpp"
#include "integrators/time_stepper.hpp"

namespace sweep {

namespace {
void refuse(const std::string& field, const std::string& why) {
  throw InputError("distributed run: " + field + ": " + why);
}
}  // namespace

DistributedStepper::DistributedStepper(const RankGroup& ranks, const Model& model,
                                       const ContactModel& cmodel, const SchemeSettings& settings,
                                       const DistributedSettings& distributed)
    : ranks_(ranks),
      settings_(distributed),
      m_(model, cmodel, settings, {}),
      d_(model, cmodel, m_.settings) {
  d_.scene_speeds = [this] { return sceneSpeeds(); };
  if (cmodel.dimension == 2 && distributed.interface == RankInterface::SplitMasses)
    refuse("interface", "split masses run on 3D spheres' rows only; 2D scenes take ordered sweeps");
  if (m_.settings.scheme != Scheme::MoreauJean) {
    if (distributed.interface == RankInterface::SplitMasses)
      refuse("interface", "split masses run scheme A only; scheme B takes ordered sweeps");
    // the stages sweep across the ranks: NLGS, which `auto` takes on grains
    for (const auto& [field, stage] :
         {std::pair{"scheme.normal_stage.solver", &m_.settings.normal_stage},
          {"scheme.friction_stage.solver", &m_.settings.friction_stage}})
      if (stage->solver != StageSolver::Nlgs && stage->solver != StageSolver::Auto)
        refuse(field, std::string(enumName(stage->solver)) +
                          " does not run on ranks; nlgs or auto (NLGS with NNCG) do");
  }
  if (m_.settings.projection.max_rounds > 0)
    refuse("scheme.projection.max_rounds", "position projection does not run on ranks");
  if (cmodel.path != DetectionPath::Analytic)
    refuse("detection.path", "only the analytic (grid) path runs on ranks");
  if (!model.actuators.empty() || !model.limits.empty() || !model.systems.empty() ||
      !model.constraints.empty())
    refuse("bodies", "actuators, joint limits, systems and constraints do not run on ranks");
  if (settings_.sweeps_per_exchange < 1)
    refuse("sweeps_per_exchange", std::to_string(settings_.sweeps_per_exchange) + " is below 1");
  if (settings_.rebalance_interval < 0)
    refuse("rebalance_interval", std::to_string(settings_.rebalance_interval) + " is negative");
  if (!(settings_.rebalance_above >= 0.0) || !std::isfinite(settings_.rebalance_above))
    refuse("rebalance_above", std::to_string(settings_.rebalance_above) + " is not a ratio");
  if (!(settings_.ghost_width >= 0.0))
    refuse("ghost_width", std::to_string(settings_.ghost_width) + " is not a width");
  findFreeParticles(model, d_.model_data, cmodel, d_.problem_ws);
  const auto& spheres = d_.problem_ws.sphere_particles;
  // 2D: a disk centred on a body of its own, free in the plane
  std::vector<char> centred_disk(model.bodies.size(), 0), other_shape(model.bodies.size(), 0);
  for (const Geometry& g : cmodel.geometries) {
    if (g.body.kind != BodyRef::Kind::Dynamic) continue;
    const bool disk = g.shape.type == ShapeType::Disk && g.placement.translation.isZero(0.0);
    (disk ? centred_disk : other_shape)[g.body.index] = 1;
  }
  component_of_.assign(model.bodies.size(), -1);
  for (const Component& c : model.components) {
    const Body& body = model.bodies[c.first_body];
    const bool single = c.end_body == c.first_body + 1;
    const bool particle = cmodel.dimension == 3
                              ? single && spheres[c.first_body].v_index >= 0
                              : single && body.parent < 0 && body.joint.type == JointType::Planar &&
                                    centred_disk[c.first_body] && !other_shape[c.first_body];
    if (!particle)
      refuse("bodies", "'" + body.name + "' is not a free " +
                           (cmodel.dimension == 3 ? "sphere" : "disk") + ": only free " +
                           (cmodel.dimension == 3 ? "spheres" : "disks") +
                           " (and bodies without dofs) run on ranks");
    particle_body_.push_back(c.first_body);
    component_of_[c.first_body] = static_cast<int>(&c - model.components.data());
    nq_ = c.nq;
    nv_ = c.nv;
  }
  for (const Geometry& g : cmodel.geometries)
    if (g.body.kind == BodyRef::Kind::Dynamic)
      largest_diameter_ = std::max(largest_diameter_, 2.0 * g.shape.radius);
  const std::size_t bodies = model.bodies.size();
  base_inverse_mass_.assign(bodies, 0.0);
  base_inverse_inertia_.assign(bodies, 0.0);
  if (cmodel.dimension == 3)
    for (const int b : particle_body_) {
      base_inverse_mass_[b] = spheres[b].inverse_mass;
      base_inverse_inertia_[b] = spheres[b].inverse_inertia;
    }
  is_particle_.assign(bodies, 0);
  for (const int b : particle_body_) is_particle_[b] = 1;
  local_.assign(bodies, 0);
  owner_.assign(bodies, -1);
  touched_.assign(bodies, 0);
  moved_.assign(bodies, 0);
  multiplicity_.assign(bodies, 1.0);
  glued_index_.assign(bodies, -1);
  contact_count_.assign(bodies, 0);
  const auto size = static_cast<std::size_t>(ranks_.size());
  touch_out_.resize(size);
  touch_in_.resize(size);
  send_.resize(size);
  receive_.resize(size);
}

Vector3 DistributedStepper::centre(const Body& body, const VectorX& q) const {
  if (body.joint.type == JointType::Planar)
    return body.joint_placement.apply(body.joint.plane_x * q[body.q_index] +
                                      body.joint.plane_y * q[body.q_index + 1]);
  // a free sphere's joint frame has the world's axes (findFreeParticles)
  return body.joint_placement.translation + q.segment<3>(body.q_index);
}

void DistributedStepper::writeState(const ParticleSet& set, int i) {
  const Body& body = m_.model.bodies[set.id[i]];
  const double* payload = set.payload.data() + static_cast<std::size_t>(i) * (nq_ + nv_);
  for (int k = 0; k < nq_; ++k) d_.q[body.q_index + k] = payload[k];
  for (int k = 0; k < nv_; ++k) d_.v[body.v_index + k] = payload[nq_ + k];
}

void DistributedStepper::reset(double t, const VectorX& q, const VectorX& v) {
  d_.model_data.restrict_components = false;  // the whole state's kinematics, once
  stepping::reset(m_, d_, t, q, v);
  d_.body_rank.assign(m_.model.bodies.size(), -1);
  d_.rank = ranks_.rank();
  DecompositionSettings ds;
  ds.dimension = m_.cmodel.dimension;
  Eigen::AlignedBox3d box;
  for (const int b : particle_body_) box.extend(centre(m_.model.bodies[b], q));
  if (box.isEmpty()) box.extend(Vector3::Zero());
  ds.lower = box.min() - Vector3::Constant(largest_diameter_);
  ds.upper = box.max() + Vector3::Constant(largest_diameter_);
  const Periodicity& periodic = m_.cmodel.settings.periodic;
  if (periodic.enabled()) {
    ds.periodic[periodic.axis] = true;
    ds.lower[periodic.axis] = periodic.low;
    ds.upper[periodic.axis] = periodic.high;
  }
  ds.ghost_width = settings_.ghost_width > 0.0 ? settings_.ghost_width : 2.0 * largest_diameter_;
  base_ghost_width_ = ds.ghost_width;
  reach_ = 0.0;
  decomposition_.emplace(ranks_, ds);
  owned_.clear();
  owned_.payload_width = nq_ + nv_;
  ghosts_.clear();
  std::fill(contact_count_.begin(), contact_count_.end(), 0);
  work_counted_.clear();
  if (ranks_.rank() == 0) {  // rank 0 holds every grain until the first balance
    for (const int b : particle_body_) {
      owned_.id.push_back(b);
      owned_.position.emplace_back();
      owned_.work.push_back(1);
    }
    owned_.payload.resize(owned_.id.size() * (nq_ + nv_));
  }
  balance_now_ = true;
  steps_ = 0;
}

void DistributedStepper::refreshOwnership() {
  const int width = nq_ + nv_;
  for (int i = 0; i < owned_.size(); ++i) {
    const Body& body = m_.model.bodies[owned_.id[i]];
    owned_.position[i] = centre(body, d_.q);
    owned_.work[i] = 1 + contact_count_[owned_.id[i]];
    double* payload = owned_.payload.data() + static_cast<std::size_t>(i) * width;
    for (int k = 0; k < nq_; ++k) payload[k] = d_.q[body.q_index + k];
    for (int k = 0; k < nv_; ++k) payload[nq_ + k] = d_.v[body.v_index + k];
  }
  bool rebalance = balance_now_;
  if (!rebalance && settings_.rebalance_interval > 0 && steps_ % settings_.rebalance_interval == 0)
    rebalance = settings_.rebalance_above <= 0.0 ||
                decomposition_->imbalance(owned_) > settings_.rebalance_above;
  balance_now_ = false;
  const ExchangeStats moved =
      rebalance ? decomposition_->balance(owned_) : decomposition_->migrate(owned_);
  bytes_ += moved.bytes;
  std::fill(d_.body_rank.begin(), d_.body_rank.end(), -1);
  for (int i = 0; i < owned_.size(); ++i) {
    d_.body_rank[owned_.id[i]] = ranks_.rank();
    writeState(owned_, i);
  }
  // what this rank does not own is at rest until a ghost exchange brings it
  for (const int b : particle_body_)
    if (d_.body_rank[b] != ranks_.rank()) d_.v.segment(m_.model.bodies[b].v_index, nv_).setZero();
}

void DistributedStepper::handOverContacts() {
  // key (3), tangent1 (3), impulse (3), rolling impulse (2, with rolling resistance), scheme
  // B's staged impulses (4: normal, delta, tangent)
  std::vector<Contact>& contacts = d_.contact_data.contacts;
  const bool rolling = m_.cmodel.rolling && d_.rolling.size() == contacts.size();
  const bool staged = m_.settings.scheme != Scheme::MoreauJean;
  if (staged) d_.staged.resize(contacts.size());
  const std::size_t width = 9 + (rolling ? 2 : 0) + (staged ? 4 : 0);
  const int size = ranks_.size(), rank = ranks_.rank();
  for (int r = 0; r < size; ++r) send_[r].clear();
  handed_over_ = 0;
  std::int64_t doubles = 0;
  for (std::size_t c = 0; c < contacts.size(); ++c) {
    const int to = stepping::contactOwner(d_.body_rank, contacts[c]);
    if (to < 0 || to == rank) continue;
    const Contact& k = contacts[c];
    const Vector3 P = c < d_.impulse.size() ? d_.impulse[c] : Vector3::Zero();
    std::vector<double>& out = send_[to];
    out.insert(out.end(),
               {static_cast<double>(k.key.geometry_a), static_cast<double>(k.key.geometry_b),
                static_cast<double>(k.key.feature), k.tangent1.x(), k.tangent1.y(), k.tangent1.z(),
                P.x(), P.y(), P.z()});
    if (rolling) out.insert(out.end(), {d_.rolling[c].x(), d_.rolling[c].y()});
    if (staged) {
      const StagedImpulse& s = d_.staged[c];
      out.insert(out.end(), {s.normal, s.delta, s.tangent.x(), s.tangent.y()});
    }
    ++handed_over_;
    doubles += static_cast<std::int64_t>(width);
  }
  bytes_ += 8 * doubles;
  ranks_.exchange(send_, receive_);
  std::size_t arriving = 0;
  for (int r = 0; r < size; ++r) arriving += receive_[r].size() / width;
  if (arriving == 0) return;
  // the contacts handed away stay in this list too, unmatched: this rank no longer detects them
  const int kept = static_cast<int>(contacts.size());
  d_.impulse.resize(contacts.size(), Vector3::Zero());
  if (rolling) d_.rolling.resize(contacts.size(), Vector2::Zero());
  for (int r = 0; r < size; ++r)
    for (std::size_t at = 0; at + width <= receive_[r].size(); at += width) {
      const double* x = receive_[r].data() + at;
      Contact k;
      k.key = ContactKey{static_cast<int>(x[0]), static_cast<int>(x[1]), static_cast<int>(x[2])};
      k.tangent1 = Vector3(x[3], x[4], x[5]);
      // what detection reads of a previous contact is its key and frame; the rest is unread
      k.normal = k.tangent2 = k.point_a = k.point_b = Vector3::Zero();
      contacts.push_back(k);
      d_.impulse.emplace_back(x[6], x[7], x[8]);
      if (rolling) d_.rolling.emplace_back(x[9], x[10]);
      if (staged) {
        const double* y = x + (rolling ? 11 : 9);
        d_.staged.push_back(StagedImpulse{y[0], y[1], Vector2(y[2], y[3])});
      }
    }
  // detection left this rank's list sorted by key: sort the arrivals and merge
  const int n = static_cast<int>(contacts.size());
  merge_order_.resize(n);
  for (int c = 0; c < n; ++c) merge_order_[c] = c;
  auto byKey = [&](int a, int b) { return contacts[a].key < contacts[b].key; };
  std::sort(merge_order_.begin() + kept, merge_order_.end(), byKey);
  std::inplace_merge(merge_order_.begin(), merge_order_.begin() + kept, merge_order_.end(), byKey);
  merged_contacts_.resize(n);
  merged_impulse_.resize(n);
  for (int c = 0; c < n; ++c) {
    merged_contacts_[c] = contacts[merge_order_[c]];
    merged_impulse_[c] = d_.impulse[merge_order_[c]];
  }
  contacts.swap(merged_contacts_);
  d_.impulse.swap(merged_impulse_);
  if (rolling) {
    merged_rolling_.resize(n);
    for (int c = 0; c < n; ++c) merged_rolling_[c] = d_.rolling[merge_order_[c]];
    d_.rolling.swap(merged_rolling_);
  }
  if (staged) {
    merged_staged_.resize(n);
    for (int c = 0; c < n; ++c) merged_staged_[c] = d_.staged[merge_order_[c]];
    d_.staged.swap(merged_staged_);
  }
}

void DistributedStepper::receiveGhosts() {
  bytes_ += decomposition_->exchangeGhosts(owned_, ghosts_).bytes;
  for (const int b : local_bodies_) local_[b] = 0;
  local_bodies_.clear();
  for (int i = 0; i < owned_.size(); ++i) {
    const int b = static_cast<int>(owned_.id[i]);
    local_[b] = 1;
    owner_[b] = ranks_.rank();
    local_bodies_.push_back(b);
  }
  for (int i = 0; i < ghosts_.size(); ++i) {
    const int b = static_cast<int>(ghosts_.id[i]);
    if (local_[b]) continue;  // an image of an own grain, or a second image
    local_[b] = 1;
    owner_[b] = d_.body_rank[b] = decomposition_->owner(ghosts_.position[i]);
    local_bodies_.push_back(b);
    writeState(ghosts_, i);
  }
  restrictParticles(m_.cmodel, local_, d_.contact_data, &d_.body_rank, ranks_.rank());
  // the step's passes over the body trees (kinematics, dynamics, integration) take this
  // rank's own and ghost grains only: every grain is some tree of its own
  if (ranks_.size() > 1) {
    std::vector<int>& components = d_.model_data.components;
    components.clear();
    for (const int b : local_bodies_) components.push_back(component_of_[b]);
    std::sort(components.begin(), components.end());
    d_.model_data.restrict_components = true;
  }
}

void DistributedStepper::findSharedBodies() {
  for (const int b : touched_list_) touched_[b] = 0;
  touched_list_.clear();
  auto touch = [&](const Contact& contact) {
    for (const BodyRef* body : {&contact.body_a, &contact.body_b})
      if (body->kind == BodyRef::Kind::Dynamic && !touched_[body->index]) {
        touched_[body->index] = 1;
        touched_list_.push_back(body->index);
      }
  };
  // ordered sweeps: the bodies the assembled rows move; split masses, needed before the
  // assembly: every candidate's (a superset, whose extra bodies get no push)
  if (settings_.interface == RankInterface::OrderedSweeps) {
    for (int c = 0; c < d_.problem.size(); ++c)
      touch(d_.contact_data.contacts[d_.problem.contact[c]]);
  } else {
    for (const Contact& contact : d_.contact_data.contacts) touch(contact);
  }
  std::sort(touched_list_.begin(), touched_list_.end());
  const int size = ranks_.size(), rank = ranks_.rank();
  for (int r = 0; r < size; ++r) {
    touch_out_[r].clear();
    send_[r].clear();
  }
  for (const int b : touched_list_)
    if (owner_[b] != rank) {
      touch_out_[owner_[b]].push_back(b);
      send_[owner_[b]].push_back(b);
    }
  auto sent = [&] {
    std::int64_t doubles = 0;
    for (const auto& part : send_) doubles += static_cast<std::int64_t>(part.size());
    bytes_ += 8 * doubles;
  };
  sent();
  ranks_.exchange(send_, receive_);
  for (const int b : glued_) glued_index_[b] = -1;
  glued_.clear();
  for (const int b : touched_list_) multiplicity_[b] = 1.0;
  for (int r = 0; r < size; ++r) {
    touch_in_[r].clear();
    for (const double id : receive_[r]) {
      const int b = static_cast<int>(id);
      touch_in_[r].push_back(b);
      if (glued_index_[b] < 0) {  // the first rank that touches one of this rank's bodies
        glued_index_[b] = static_cast<int>(glued_.size());
        glued_.push_back(b);
        multiplicity_[b] = touched_[b] ? 1.0 : 0.0;
      }
      multiplicity_[b] += 1.0;
    }
  }
  // the touchers of each of this rank's glued bodies, in rank order
  toucher_begin_.assign(1, 0);
  toucher_rank_.clear();
  for (std::size_t g = 0; g < glued_.size(); ++g) toucher_begin_.push_back(0);
  {
    std::vector<std::vector<int>>& lists = touchers_scratch_;
    lists.resize(glued_.size());
    for (auto& list : lists) list.clear();
    for (int r = 0; r < size; ++r) {
      if (r == rank) {
        for (std::size_t g = 0; g < glued_.size(); ++g)
          if (touched_[glued_[g]]) lists[g].push_back(rank);
      }
      for (const int b : touch_in_[r])
        lists[static_cast<std::size_t>(glued_index_[b])].push_back(r);
    }
    for (std::size_t g = 0; g < glued_.size(); ++g) {
      toucher_rank_.insert(toucher_rank_.end(), lists[g].begin(), lists[g].end());
      toucher_begin_[g + 1] = static_cast<int>(toucher_rank_.size());
    }
  }
  // the reply: per body, its multiplicity and its touchers
  for (int r = 0; r < size; ++r) {
    send_[r].clear();
    for (const int b : touch_in_[r]) {
      const int g = glued_index_[b];
      send_[r].push_back(multiplicity_[b]);
      send_[r].push_back(toucher_begin_[g + 1] - toucher_begin_[g]);
      for (int t = toucher_begin_[g]; t < toucher_begin_[g + 1]; ++t)
        send_[r].push_back(toucher_rank_[t]);
    }
  }
  sent();
  ranks_.exchange(send_, receive_);
  for (int r = 0; r < size; ++r) {
    std::size_t at = 0;
    for (const int b : touch_out_[r]) {
      multiplicity_[b] = receive_[r][at++];
      const int count = static_cast<int>(receive_[r][at++]);
      glued_index_[b] = static_cast<int>(glued_.size());
      glued_.push_back(b);
      for (int t = 0; t < count; ++t) toucher_rank_.push_back(static_cast<int>(receive_[r][at++]));
      toucher_begin_.push_back(static_cast<int>(toucher_rank_.size()));
    }
  }
  shared_count_ = 0;
  split_.clear();
  for (const int b : glued_)
    if (touched_[b] && multiplicity_[b] > 1.0) {
      ++shared_count_;
      if (settings_.interface == RankInterface::SplitMasses) split_.push_back(b);
    }
  if (settings_.interface == RankInterface::OrderedSweeps) colourRanks();
}

const StepStats& DistributedStepper::step() {
  using namespace stepping;
  d_.stats.step += 1;
  d_.model_data.threads = m_.threads;
  bytes_ = 0;
  dstats_.ghost_widenings = 0;
  refreshOwnership();
  // the band of ghosts: the base width, or wider where the last step's detection reached
  // further (a step needing more widens it again before its detection)
  decomposition_->setGhostWidth(std::max(base_ghost_width_, kGhostSlack * reach_));
  receiveGhosts();
  handOverContacts();
  midpoint(m_, d_);
  // the margin check after the solve: stages 2 to 5 again on every rank, with the margins the
  // whole scene's end velocities need (scene_speeds)
  const bool verify_margin =
      m_.cmodel.settings.verify_margin && m_.settings.normal_law != NormalLaw::Vel;
  if (verify_margin) d_.contact_dv_start = d_.contact_dv;
  detectAndSolve({});
  d_.stats.redetections = 0;
  d_.stats.margin_outrun = false;
  for (DetectionMargins needed = verify_margin ? marginNeeded(m_, d_) : DetectionMargins{};
       needed.balls > 0.0 || needed.others > 0.0; needed = marginNeeded(m_, d_)) {
    if (d_.stats.redetections == TimeStepper::kMaxRedetections) {
      d_.stats.margin_outrun = true;
      break;
    }
    ++d_.stats.redetections;
    redoStep(m_, d_, needed, [&](const DetectionMargins& margins) { detectAndSolve(margins); });
  }
  update(m_, d_);
  // the free velocity of a grain this rank neither owns nor sees was not computed: at rest
  for (const int b : particle_body_)
    if (!local_[b]) d_.v.segment(m_.model.bodies[b].v_index, nv_).setZero();
  findFailure();
  if (failure_.empty()) stepping::diagnose(m_, d_);
  wrapPeriodic(m_.cmodel, d_.q);
  for (const int b : work_counted_) contact_count_[b] = 0;
  work_counted_.clear();
  // the balance's work: each row this rank solves counts 2, shared by the sides this rank
  // owns (a row across a cut, or on a wall, counts whole on the grain of this rank's)
  const int rank = ranks_.rank();
  for (int c = 0; c < d_.problem.size(); ++c) {
    const Contact& contact = d_.contact_data.contacts[d_.problem.contact[c]];
    auto own = [&](const BodyRef& body) {
      return body.kind == BodyRef::Kind::Dynamic && d_.body_rank[body.index] == rank;
    };
    const bool a = own(contact.body_a), b = own(contact.body_b);
    for (const auto& [mine, body] :
         {std::pair{a, contact.body_a.index}, {b, contact.body_b.index}}) {
      if (!mine) continue;
      if (contact_count_[body] == 0) work_counted_.push_back(body);
      contact_count_[body] += a && b ? 1 : 2;
    }
  }
  carried_ = 0;
  for (const Contact& contact : d_.contact_data.contacts) carried_ += contact.previous >= 0 ? 1 : 0;
  ++steps_;
  reduceStats();
  return d_.stats;
}

void DistributedStepper::detectAndSolve(const DetectionMargins& at_least) {
  using namespace stepping;
  detect(m_, d_, at_least);
  // the ghosts must hold every grain an owned grain may touch (the margins are the same on
  // every rank: scene_speeds): where they do not, the ghosts come again from a wider band
  const double margin = std::max(d_.stats.margin, d_.stats.margin_balls);
  reach_ = largest_diameter_ + margin;
  if (reach_ > decomposition_->settings().ghost_width) {
    if (!decomposition_->setGhostWidth(kGhostSlack * reach_))
      throw CollectiveError("distributed run, step " + std::to_string(d_.stats.step) +
                            ": the detection margin " + std::to_string(margin) +
                            " m plus the largest diameter needs ghosts from a band wider than "
                            "half the period; shorten the step");
    undoDetection(m_, d_);
    receiveGhosts();
    midpoint(m_, d_);
    detect(m_, d_, at_least);
    ++dstats_.ghost_widenings;
  }
  freeVelocity(m_, d_);
  const bool ordered = settings_.interface == RankInterface::OrderedSweeps;
  if (!ordered) {
    findSharedBodies();
    splitMasses(true);
  }
  assemble(m_, d_);
  // one solve of the rows assembled: with candidate screening, each round's admitted
  // candidates change the rows, and so the bodies two ranks share
  auto solve_once = [&] {
    if (ordered) findSharedBodies();
    // a split mass reaches only the compact sphere rows, which read it from the workspace
    for (int c = 0; !ordered && c < d_.problem.size(); ++c) {
      if (d_.problem.sphereForm(c) >= 0) continue;
      const Contact& contact = d_.contact_data.contacts[d_.problem.contact[c]];
      for (const BodyRef* body : {&contact.body_a, &contact.body_b})
        if (body->kind == BodyRef::Kind::Dynamic && multiplicity_[body->index] > 1.0 &&
            touched_[body->index])
          throw std::logic_error("distributed run: a shared body's row is not a sphere row");
    }
    const bool scheme_a = m_.settings.scheme == Scheme::MoreauJean;
    if (ranks_.size() == 1)
      scheme_a ? solveMoreauJean(m_, d_) : solveCatchingUp(m_, d_);
    else if (!ordered)
      solveAcrossRanks();
    else
      scheme_a ? solveInRankOrder() : solveCatchingUpInRankOrder();
  };
  // every rank repeats a screening round when any rank admitted a candidate
  auto agree = [&](int admitted) {
    admitted_.assign(1, admitted);
    ranks_.sum(admitted_);
    return static_cast<int>(admitted_[0]);
  };
  // adhesive rows (step_data.hpp): on several ranks each row's -h F joins its rank's push,
  // which the ranks sum on shared bodies (startFromWarmStart)
  solveScreened(m_, d_, solve_once, agree, ranks_.size() > 1);
  splitMasses(false);
}

MarginSpeeds DistributedStepper::sceneSpeeds() {
  // each rank measures the grains it owns (the walls, plates and blades every rank holds count
  // on each, alike); the ranks' parts combine into the single process's speeds
  counted_.assign(m_.model.bodies.size(), 0);
  for (int i = 0; i < owned_.size(); ++i) counted_[owned_.id[i]] = 1;
  MarginSpeeds mine =
      marginSpeeds(m_.model, d_.model_data, m_.cmodel, d_.t + 0.5 * m_.settings.h, &counted_);
  std::vector<double>& high = speed_bounds_;  // the lows negated: one all-reduce of maxima
  high.assign({mine.fastest_shape, mine.ball_high.x(), mine.ball_high.y(), mine.ball_high.z(),
               mine.ball_fastest, -mine.ball_low.x(), -mine.ball_low.y(), -mine.ball_low.z()});
  ranks_.max(high);
  MarginSpeeds scene;
  scene.fastest_shape = high[0];
  scene.ball_high = Vector3(high[1], high[2], high[3]);
  scene.ball_fastest = high[4];
  scene.ball_low = -Vector3(high[5], high[6], high[7]);
  return scene;
}

}  // namespace sweep
