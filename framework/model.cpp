#include "framework/model.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Cholesky>
#include <limits>
#include <map>
#include <sstream>

#include "framework/data.hpp"
#include "framework/error.hpp"
#include "framework/memory.hpp"

namespace sweep {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace

DrivenBody DrivenBody::fixed(const std::string& name, const Pose& pose) {
  return DrivenBody{name, [pose](double) { return pose; },
                    [](double) { return Vector6::Zero().eval(); }};
}

DrivenBody DrivenBody::constantTwist(const std::string& name, const Pose& pose0,
                                     const Vector3& linear_velocity,
                                     const Vector3& angular_velocity) {
  // the origin translates at linear_velocity while the body spins about it
  auto pose = [=](double t) {
    Pose p = pose0;
    p.translation += linear_velocity * t;
    const double rate = angular_velocity.norm();
    if (rate > 0.0) {
      p.rotation =
          Eigen::AngleAxisd(rate * t, angular_velocity / rate).toRotationMatrix() * p.rotation;
    }
    return p;
  };
  auto twist = [=](double) {
    Vector6 m;
    m << angular_velocity, linear_velocity;
    return m;
  };
  return DrivenBody{name, pose, twist};
}

DrivenBody DrivenBody::keyframes(const std::string& name, const Matrix3& rotation,
                                 const std::vector<double>& times,
                                 const std::vector<Vector3>& positions) {
  if (times.empty() || times.size() != positions.size())
    throw InputError("driven body '" + name + "': keyframes need as many times as positions");
  for (std::size_t k = 0; k < times.size(); ++k) {
    if (!std::isfinite(times[k]) || !positions[k].allFinite())
      throw InputError("driven body '" + name + "': keyframe " + std::to_string(k) +
                       " is not finite");
    if (k > 0 && !(times[k] > times[k - 1]))
      throw InputError("driven body '" + name + "': keyframe times must increase, got " +
                       formatValue(times[k - 1]) + " then " + formatValue(times[k]));
  }
  // the segment holding t: [times[k], times[k+1]), or -1 / last outside the span
  auto segment = [times](double t) {
    const auto upper = std::upper_bound(times.begin(), times.end(), t);
    return static_cast<int>(upper - times.begin()) - 1;
  };
  auto pose = [=](double t) {
    Pose p;
    p.rotation = rotation;
    const int k = segment(t);
    if (k < 0) {
      p.translation = positions.front();
    } else if (k + 1 >= static_cast<int>(times.size())) {
      p.translation = positions.back();
    } else {
      const double s = (t - times[k]) / (times[k + 1] - times[k]);
      p.translation = (1.0 - s) * positions[k] + s * positions[k + 1];
    }
    return p;
  };
  auto twist = [=](double t) {
    Vector6 m = Vector6::Zero();
    const int k = segment(t);
    if (k >= 0 && k + 1 < static_cast<int>(times.size()))
      m.tail<3>() = (positions[k + 1] - positions[k]) / (times[k + 1] - times[k]);
    return m;
  };
  return DrivenBody{name, pose, twist};
}

int Model::bodyIndex(const std::string& name) const {
  for (size_t i = 0; i < bodies.size(); ++i)
    if (bodies[i].name == name) return static_cast<int>(i);
  throw InputError("model: no body named '" + name + "'");
}

int Model::jointIndex(const std::string& name) const {
  for (size_t i = 0; i < bodies.size(); ++i)
    if (bodies[i].joint_name == name) return static_cast<int>(i);
  throw InputError("model: no joint named '" + name + "'");
}

std::vector<std::string> Model::dofNames() const {
  std::vector<std::string> names;
  names.reserve(nv);
  for (const Body& body : bodies) {
    if (body.joint.type == JointType::Planar) {
      for (const char* s : {":x", ":y", ":theta"}) names.push_back(body.joint_name + s);
    } else if (body.joint.type == JointType::Floating) {
      for (const char* s : {":vx", ":vy", ":vz", ":wx", ":wy", ":wz"})
        names.push_back(body.joint_name + s);
    } else if (body.joint.nv() == 1) {
      names.push_back(body.joint_name);
    }
  }
  for (const EquationSystem& system : systems)
    for (int k = 0; k < system.nv; ++k) names.push_back(system.name + ":" + std::to_string(k));
  return names;
}

int Model::dofIndex(const std::string& name) const {
  const std::vector<std::string> names = dofNames();
  for (int k = 0; k < static_cast<int>(names.size()); ++k)
    if (names[k] == name) return k;
  throw InputError("model: no degree of freedom named '" + name + "'");
}

VectorX Model::neutralConfiguration() const {
  VectorX q = VectorX::Zero(nq);
  for (const Body& b : bodies)
    if (b.joint.type == JointType::Floating) q[b.q_index + 6] = 1.0;
  for (const Component& c : components)
    if (c.system >= 0 && systems[c.system].reference.size() == c.nq)
      q.segment(c.q_index, c.nq) = systems[c.system].reference;
  return q;
}

int ModelBuilder::addBody(int parent, const std::string& joint_name, const Joint& joint,
                          const Pose& joint_placement, const Inertia& inertia,
                          const std::string& body_name) {
  const auto fail = [&](const std::string& why) {
    throw InputError(source_ + ": body '" + body_name + "': " + why);
  };
  if (parent < -1 || parent >= bodyCount())
    fail("parent index " + std::to_string(parent) + " does not exist");
  if (!(inertia.mass >= 0.0)) fail("mass must be >= 0, got " + formatValue(inertia.mass));
  if (!inertia.com.allFinite() || !inertia.inertia_com.allFinite())
    fail("inertia has non-finite entries");
  if (!joint_placement.rotation.allFinite() || !joint_placement.translation.allFinite())
    fail("joint placement has non-finite entries");
  if (!joint.axis.allFinite() || std::abs(joint.axis.norm() - 1.0) > 1e-9)
    fail("joint axis must be a unit vector");
  Body b;
  b.name = body_name;
  b.joint_name = joint_name;
  b.parent = parent;
  // a planar joint's in-plane axes follow from its normal, however the Joint was assembled
  b.joint = joint.type == JointType::Planar ? Joint::planar(joint.axis) : joint;
  b.joint_placement = joint_placement;
  b.inertia = inertia;
  bodies_.push_back(b);
  return bodyCount() - 1;
}

void ModelBuilder::addJointLimits(int body, double lower, double upper) {
  if (body < 0 || body >= bodyCount()) throw InputError(source_ + ": joint limit on unknown body");
  const Body& b = bodies_[body];
  if (!b.joint.hasLimits())
    throw InputError(source_ + ": joint '" + b.joint_name + "': limits need a 1-dof " +
                     "revolute or prismatic joint, got " + toString(b.joint.type));
  if (!(lower <= upper) || lower == kInf || upper == -kInf)
    throw InputError(source_ + ": joint '" + b.joint_name + "': lower limit " + formatValue(lower) +
                     " exceeds upper limit " + formatValue(upper));
  if (lower > -kInf) limits_.push_back(JointLimit{body, 0, 0, lower, +1.0});
  if (upper < kInf) limits_.push_back(JointLimit{body, 0, 0, upper, -1.0});
}

void ModelBuilder::addCollision(const CollisionGeometry& geometry) {
  if (geometry.body < 0 || geometry.body >= bodyCount())
    throw InputError(source_ + ": collision geometry '" + geometry.name + "' on unknown body");
  collisions_.push_back(geometry);
}

void ModelBuilder::addVisual(const CollisionGeometry& geometry) {
  if (geometry.body < 0 || geometry.body >= bodyCount())
    throw InputError(source_ + ": visual geometry '" + geometry.name + "' on unknown body");
  visuals_.push_back(geometry);
}

void ModelBuilder::addDrivenBody(const DrivenBody& body) {
  if (!body.pose || !body.twist)
    throw InputError(source_ + ": driven body '" + body.name + "' needs a pose and a twist");
  driven_.push_back(body);
}

void ModelBuilder::addSystem(const EquationSystem& system) {
  const std::string who = source_ + ": system '" + system.name + "'";
  if (system.nq < 1 || system.nv < 1 || system.nq > 100000 || system.nv > 100000)
    throw InputError(who + ": nq and nv must be in [1, 10^5], got " + std::to_string(system.nq) +
                     " and " + std::to_string(system.nv));
  if (!system.mass) throw InputError(who + ": needs a mass matrix function");
  if (!system.integrate && system.nq != system.nv)
    throw InputError(who + ": nq = " + std::to_string(system.nq) + " differs from nv = " +
                     std::to_string(system.nv) + ", so it needs its integrate function");
  if (system.reference.size() != 0 &&
      (system.reference.size() != system.nq || !system.reference.allFinite()))
    throw InputError(who + ": its reference configuration must have nq finite entries");
  systems_.push_back(system);
}

void ModelBuilder::addConstraint(const ConstraintFunction& constraint) {
  const std::string who = source_ + ": constraint '" + constraint.name + "'";
  if (!constraint.gap || !constraint.normal)
    throw InputError(who + ": needs a gap function and a normal function");
  if (!(constraint.friction >= 0.0 && std::isfinite(constraint.friction)))
    throw InputError(who + ": friction must be >= 0, got " + formatValue(constraint.friction));
  if (!(constraint.restitution >= 0.0 && constraint.restitution <= 1.0))
    throw InputError(who + ": restitution must be in [0, 1], got " +
                     formatValue(constraint.restitution));
  if (constraint.friction > 0.0 && !constraint.tangent)
    throw InputError(who + ": friction needs a tangent function");
  if (constraint.bilateral && (constraint.friction != 0.0 || constraint.restitution != 0.0))
    throw InputError(who + ": a bilateral constraint takes no friction and no restitution");
  constraints_.push_back(constraint);
}

void ModelBuilder::addJointCoupling(int follower, int leader, double multiplier, double offset) {
  if (follower < 0 || follower >= bodyCount() || leader < 0 || leader >= bodyCount())
    throw InputError(source_ + ": joint coupling on an unknown body");
  const Body& f = bodies_[follower];
  const Body& l = bodies_[leader];
  const std::string who =
      source_ + ": joint '" + f.joint_name + "' following '" + l.joint_name + "'";
  if (follower == leader) throw InputError(who + ": a joint cannot follow itself");
  for (const Body* b : {&f, &l})
    if (b->joint.nq() != 1)
      throw InputError(who + ": a coupling needs two 1-dof joints (revolute, continuous or " +
                       "prismatic), joint '" + b->joint_name + "' is " + toString(b->joint.type));
  if (!std::isfinite(multiplier) || !std::isfinite(offset))
    throw InputError(who + ": multiplier and offset must be finite, got " +
                     formatValue(multiplier) + " and " + formatValue(offset));
  for (const JointCoupling& c : couplings_)
    if (c.follower == follower)
      throw InputError(who + ": it already follows '" + bodies_[c.leader].joint_name +
                       "'; a joint follows one leader");
  couplings_.push_back(JointCoupling{follower, leader, multiplier, offset});
  // a chain of couplings that closes (a follows b follows a) fixes no joint and leaves the
  // constraints singular: walk up from the new follower
  for (int at = leader, steps = 0;; ++steps) {
    if (at == follower)
      throw InputError(who + ": the couplings form a cycle through joint '" + f.joint_name +
                       "'; a chain of mimic joints must end at a joint that follows none");
    const auto up = std::find_if(couplings_.begin(), couplings_.end(),
                                 [&](const JointCoupling& c) { return c.follower == at; });
    if (up == couplings_.end() || steps > static_cast<int>(couplings_.size())) break;
    at = up->leader;
  }
}

void ModelBuilder::setGravity(const Vector3& gravity) {
  if (!gravity.allFinite()) throw InputError(source_ + ": gravity has non-finite entries");
  gravity_ = gravity;
}

Model ModelBuilder::build() const {
  const int n = bodyCount();
  std::vector<std::vector<int>> children(n);
  std::vector<int> roots;
  for (int i = 0; i < n; ++i) {
    if (bodies_[i].parent < 0)
      roots.push_back(i);
    else
      children[bodies_[i].parent].push_back(i);
  }
  std::map<std::string, int> names;
  for (int i = 0; i < n; ++i) {
    if (!names.emplace(bodies_[i].name, i).second)
      throw InputError(source_ + ": two bodies are named '" + bodies_[i].name + "'");
  }

  // depth-first order per root: parents precede children, components are contiguous
  std::vector<int> order;
  order.reserve(n);
  std::vector<int> stack;
  for (int root : roots) {
    stack.push_back(root);
    while (!stack.empty()) {
      const int i = stack.back();
      stack.pop_back();
      order.push_back(i);
      for (auto c = children[i].rbegin(); c != children[i].rend(); ++c) stack.push_back(*c);
    }
  }
  std::vector<int> new_index(n);
  for (int k = 0; k < n; ++k) new_index[order[k]] = k;

  Model model;
  model.gravity = gravity_;
  model.bodies.reserve(n);
  int iq = 0, iv = 0;
  for (int k = 0; k < n; ++k) {
    Body b = bodies_[order[k]];
    if (b.parent >= 0) b.parent = new_index[b.parent];
    b.q_index = iq;
    b.v_index = iv;
    iq += b.joint.nq();
    iv += b.joint.nv();
    if (b.parent < 0) {
      Component c;
      c.first_body = k;
      c.q_index = b.q_index;
      c.v_index = b.v_index;
      model.components.push_back(c);
    }
    b.component = static_cast<int>(model.components.size()) - 1;
    model.bodies.push_back(b);
  }
  const std::size_t body_components = model.components.size();
  for (size_t c = 0; c < body_components; ++c) {
    Component& comp = model.components[c];
    comp.end_body = c + 1 < body_components ? model.components[c + 1].first_body : n;
    comp.nq = (c + 1 < body_components ? model.components[c + 1].q_index : iq) - comp.q_index;
    comp.nv = (c + 1 < body_components ? model.components[c + 1].v_index : iv) - comp.v_index;
    const Body& root = model.bodies[comp.first_body];
    const bool single = comp.end_body == comp.first_body + 1;
    const bool com_at_origin = root.inertia.com.norm() == 0.0;
    switch (root.joint.type) {
      case JointType::Revolute:
      case JointType::Continuous:
      case JointType::Prismatic:
      case JointType::Fixed:
        comp.constant_mass = single;
        break;
      case JointType::Planar:
      case JointType::Floating:
        comp.constant_mass = single && com_at_origin;
        break;
    }
  }
  // systems by their equations: components without bodies, after the trees
  for (const EquationSystem& system : systems_) {
    Component comp;
    comp.first_body = comp.end_body = n;
    comp.q_index = iq;
    comp.v_index = iv;
    comp.nq = system.nq;
    comp.nv = system.nv;
    comp.constant_mass = system.constant_mass;
    comp.system = static_cast<int>(model.systems.size());
    model.components.push_back(comp);
    model.systems.push_back(system);
    iq += system.nq;
    iv += system.nv;
  }
  model.nq = iq;
  model.nv = iv;
  model.constraints = constraints_;
  for (const JointCoupling& c : couplings_) {
    model.couplings.push_back(
        JointCoupling{new_index[c.follower], new_index[c.leader], c.multiplier, c.offset});
    const Body& f = model.bodies[new_index[c.follower]];
    const Body& l = model.bodies[new_index[c.leader]];
    const int fq = f.q_index, lq = l.q_index, fv = f.v_index, lv = l.v_index, nv = iv;
    const double multiplier = c.multiplier, offset = c.offset;
    ConstraintFunction k;
    k.name = "mimic '" + f.joint_name + "'";
    k.gap = [=](const VectorX& q) { return q[fq] - multiplier * q[lq] - offset; };
    k.normal = [=](const VectorX&) {
      VectorX w = VectorX::Zero(nv);
      w[fv] = 1.0;
      w[lv] -= multiplier;
      return w;
    };
    k.bilateral = true;
    model.constraints.push_back(std::move(k));
  }
  for (JointLimit l : limits_) {
    l.body = new_index[l.body];
    l.q_index = model.bodies[l.body].q_index;
    l.v_index = model.bodies[l.body].v_index;
    model.limits.push_back(l);
  }
  for (CollisionGeometry g : collisions_) {
    g.body = new_index[g.body];
    model.collisions.push_back(g);
  }
  for (CollisionGeometry g : visuals_) {
    g.body = new_index[g.body];
    model.visuals.push_back(g);
  }
  model.driven_bodies = driven_;
  model.notes = notes_;

  // Each tree's mass matrix is a dense nv x nv block, held about four times (the block and its
  // factor, in this check's Data and in the time stepper's): a chain of 10^5 links would ask
  // for 320 GB. Refuse it here, naming the need, rather than fail inside the allocator.
  double dense_bytes = 0.0;
  const Component* largest = nullptr;
  for (const Component& comp : model.components) {
    dense_bytes += 4.0 * 8.0 * static_cast<double>(comp.nv) * static_cast<double>(comp.nv);
    if (!largest || comp.nv > largest->nv) largest = &comp;
  }
  if (largest)
    requireMemory(dense_bytes,
                  source_ + ": the mass matrix of " +
                      (largest->system >= 0 ? "system '" + model.systems[largest->system].name + "'"
                                            : "the tree rooted at body '" +
                                                  model.bodies[largest->first_body].name + "'") +
                      " (" + std::to_string(largest->nv) + " degrees of freedom)");

  // every degree of freedom must move some inertia, or M is singular in every configuration
  // Data's constructor has just built every block at the neutral configuration
  Data data(model);
  for (const Component& comp : model.components) {
    if (comp.nv == 0) continue;
    const MatrixX& block = data.mass_blocks[&comp - model.components.data()];
    Eigen::LLT<MatrixX> llt(block);
    const double max_diagonal = block.diagonal().maxCoeff();
    if (llt.info() != Eigen::Success ||
        llt.matrixLLT().diagonal().array().square().minCoeff() < 1e-12 * max_diagonal) {
      std::ostringstream msg;
      if (comp.system >= 0)
        msg << source_ << ": system '" << model.systems[comp.system].name
            << "': its mass matrix at the reference configuration is not positive definite";
      else
        msg << source_ << ": mass matrix of the tree rooted at body '"
            << model.bodies[comp.first_body].name
            << "' is singular: some joint moves no mass or inertia";
      throw InputError(msg.str());
    }
  }
  return model;
}

void resolveJointCouplings(const Model& model, VectorX& q, const std::vector<bool>& given) {
  // leaders first: a follower's depth is the length of its chain of leaders
  const int n = static_cast<int>(model.bodies.size());
  std::vector<int> coupling_of(n, -1);
  for (std::size_t k = 0; k < model.couplings.size(); ++k)
    coupling_of[model.couplings[k].follower] = static_cast<int>(k);
  std::vector<int> depth(model.couplings.size(), -1);
  std::vector<int> chain;
  for (std::size_t k = 0; k < model.couplings.size(); ++k) {
    chain.clear();
    int at = static_cast<int>(k);
    while (at >= 0 && depth[at] < 0) {
      chain.push_back(at);
      at = coupling_of[model.couplings[at].leader];
    }
    int d = at >= 0 ? depth[at] : 0;
    for (auto c = chain.rbegin(); c != chain.rend(); ++c) depth[*c] = ++d;
  }
  std::vector<int> order(model.couplings.size());
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = static_cast<int>(k);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return depth[a] < depth[b]; });
  for (int k : order) {
    const JointCoupling& c = model.couplings[k];
    if (!given.empty() && given[c.follower]) continue;
    q[model.bodies[c.follower].q_index] =
        c.multiplier * q[model.bodies[c.leader].q_index] + c.offset;
  }
}

void rejectBrokenJoints(const Model& model, const VectorX& q, double max_violation,
                        const std::string& where, const std::string& when) {
  for (const JointLimit& l : model.limits) {
    const double value = q[l.q_index];
    const double past = -l.side * (value - l.bound);
    if (!(past > max_violation)) continue;
    const std::string unit =
        model.bodies[l.body].joint.type == JointType::Prismatic ? " m" : " rad";
    throw InputError(where + ": joint '" + model.bodies[l.body].joint_name + "' is at " +
                     formatValue(value) + unit + " " + when + ", past its " +
                     (l.side > 0 ? "lower" : "upper") + " limit " + formatValue(l.bound) + " by " +
                     formatValue(past) + " (more than " + formatValue(max_violation) +
                     "): start it inside its limits");
  }
  for (const JointCoupling& c : model.couplings) {
    const Body& f = model.bodies[c.follower];
    const Body& l = model.bodies[c.leader];
    const double wanted = c.multiplier * q[l.q_index] + c.offset;
    const double off = std::abs(q[f.q_index] - wanted);
    if (!(off > max_violation)) continue;
    throw InputError(where + ": joint '" + f.joint_name + "' is at " + formatValue(q[f.q_index]) +
                     " " + when + ", but its mimic coupling to '" + l.joint_name + "' (at " +
                     formatValue(q[l.q_index]) + ") needs " + formatValue(c.multiplier) + " * " +
                     formatValue(q[l.q_index]) + " + " + formatValue(c.offset) + " = " +
                     formatValue(wanted) + ": set it so, or leave it unset to follow its leader");
  }
}

}  // namespace sweep
