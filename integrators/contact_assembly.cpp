// The assembly of the contact problem (integrators/contact_assembly.hpp): the rows counted,
// written and numbered, joint limits and constraints appended, islands.
#include <omp.h>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "framework/parallel.hpp"
#include "integrators/contact_assembly.hpp"

namespace sweep {

namespace {

// Whether a row in body form may take the compact sphere form: every moving side a sphere
// particle (call after rowInBodyForm returned true for the contact).
bool sphereRowFits(const Contact& contact, const ContactProblemWorkspace& workspace) {
  for (const BodyRef& body : {contact.body_a, contact.body_b})
    if (body.kind == BodyRef::Kind::Dynamic && workspace.sphere_particles[body.index].v_index < 0)
      return false;
  return true;
}

// Under VEL a limit or a constraint by functions is closed at gap <= kClosedGap (m or rad):
// a state placed on the constraint lands a few ulps off it, and must not start open.
constexpr double kClosedGap = 1e-12;

}  // namespace

void ProblemAssembly::run(const std::vector<char>* deferred, int threads) {
  p.dimension = cmodel.dimension;
  p.rolling = J.rolling;
  p.bilateral.clear();
  if (p.dimension == 3) findFreeParticles(model, data, cmodel, ws);  // before threads read it
  forEachIndex(static_cast<int>(ws.component_parent.size()), threads,
               [&](int i) { ws.component_parent[i] = i; });
  writeContactRows(deferred, threads);
  appendJointLimits();
  appendConstraints();
  numberIslands(threads);
  if (position_level) {  // no driven body's velocity, and so no restitution term either
    std::fill(p.known.begin(), p.known.end(), Vector3::Zero());
    std::fill(p.rolling_known.begin(), p.rolling_known.end(), Vector2::Zero());
    std::fill(p.velocity_start.begin(), p.velocity_start.end(), Vector3::Zero());
    p.normal_bias = p.gap;
  }
  // packed rows have no bilateral case: such problems take the generic paths
  if (p.pack_rows && p.bilateral.empty()) {
    p.pack2d();
    p.pack3d();
  } else {
    p.rows2d.clear();
    p.packed_slot.clear();
  }
}

void ProblemAssembly::sizeRows(int rows) {
  p.contact.resize(rows);
  p.begin.resize(rows + 1);
  p.minv_begin.resize(rows + 1);
  p.begin[0] = p.minv_begin[0] = 0;
  p.diagonal.resize(rows);
  p.row_body_form.resize(rows);
  p.row_sphere.resize(rows);
  p.delassus.resize(rows);
  p.delassus_inverse.resize(rows);
  p.normal_compliance_inverse.resize(rows);
  p.known.resize(rows);
  p.gap.resize(rows);
  p.friction.resize(rows);
  p.restitution.resize(rows);
  p.velocity_start.resize(rows);
  p.normal_bias.resize(rows);
  p.row_components.resize(rows);
  ws.row_component.resize(rows);
  const int rolling_rows = p.rolling ? rows : 0;
  p.rolling_known.resize(rolling_rows);
  p.rolling_delassus.resize(rolling_rows);
  p.rolling_bound.resize(rolling_rows);
}

void ProblemAssembly::sizeEntries(int entries, int minv_entries) {
  p.dof.resize(entries);
  p.h.resize(entries);
  p.h_inverse_mass.resize(entries);
  p.rolling_h.resize(p.rolling ? entries : 0);
  p.minv_dof.resize(minv_entries);
  p.minv_h.resize(minv_entries);
  p.rolling_minv_h.resize(p.rolling ? minv_entries : 0);
}

// The union-find links a root under the smaller one, so every root is the smallest component
// of its set: the sets and their roots do not depend on the order of the joins, and rows may
// join on several threads at once (Anderson & Woll's wait-free scheme, a compare-and-swap per
// link; path halving's stores may race, and any value they leave is still an ancestor).
int ProblemAssembly::root(int c) {
  int* parent = ws.component_parent.data();
  for (;;) {
    const int up = __atomic_load_n(&parent[c], __ATOMIC_ACQUIRE);
    if (up == c) return c;
    const int above = __atomic_load_n(&parent[up], __ATOMIC_ACQUIRE);
    if (above != up) __atomic_store_n(&parent[c], above, __ATOMIC_RELEASE);
    c = above;
  }
}

void ProblemAssembly::join(int first, int second) {
  int* parent = ws.component_parent.data();
  for (;;) {
    int a = root(first), b = root(second);
    if (a == b) return;
    if (a < b) std::swap(a, b);  // a, the larger root, goes under b
    int expected = a;
    if (__atomic_compare_exchange_n(&parent[a], &expected, b, false, __ATOMIC_ACQ_REL,
                                    __ATOMIC_ACQUIRE))
      return;
    first = a;  // a gained a parent meanwhile: join from where it went
    second = b;
  }
}

void ProblemAssembly::joinComponents(const std::vector<int>& touched) {
  for (int comp : touched) join(touched.front(), comp);
}

bool ProblemAssembly::entryComponents(const int* dofs, int count, std::vector<int>& touched) {
  touched.clear();
  bool diagonal_row = true;
  for (int k = 0; k < count; ++k) {
    diagonal_row = diagonal_row && data.constant_inverse_diagonal[dofs[k]] > 0.0;
    const int comp = ws.dof_component[dofs[k]];
    if (std::find(touched.begin(), touched.end(), comp) == touched.end()) touched.push_back(comp);
  }
  return diagonal_row;
}

int ProblemAssembly::minvEntries(const std::vector<int>& touched) {
  int count = 0;
  for (int comp : touched)
    count += data.has_constant_inverse6[comp] ? 6 : model.components[comp].nv;
  return count;
}

void ProblemAssembly::writeContactRows(const std::vector<char>* deferred, int threads) {
  const int m = static_cast<int>(cdata.contacts.size());
  if (m < kParallelItems) threads = 1;
  threads = std::max(threads, 1);
  if (static_cast<int>(ws.thread_touched.size()) < threads) ws.thread_touched.resize(threads);
  if (static_cast<int>(ws.entry_scratch.size()) < threads) {
    ws.entry_scratch.resize(threads);
    for (ContactProblemWorkspace::EntryRowScratch& scratch : ws.entry_scratch)
      scratch.minv_slot.resize(model.nv, -1);
  }
  classifyContacts(deferred, threads);
  const int rows = numberRows();
  parallelFor(rows, threads, [&](int pc) {
    const int c = p.contact[pc];
    const int thread = omp_get_thread_num();
    std::vector<int>& touched = ws.thread_touched[thread];
    switch (ws.row_kind[c]) {
      case kSphereRow:
        sphereRow(pc, cdata.contacts[c], touched);
        break;
      case kBodyFormRow:
        bodyFormRow(pc, cdata.contacts[c], touched);
        break;
      case kDiagonalRow:
      case kEntryRow:
        contactEntryRow(pc, c, touched, ws.entry_scratch[thread]);
        break;
      default:
        break;
    }
  });
  for (int pc = 0; pc < rows; ++pc) {
    if (ws.row_kind[p.contact[pc]] != kSerialRow) continue;
    contactEntryRow(pc, p.contact[pc], ws.touched, ws.entry_scratch[0]);
    joinComponents(ws.touched);
  }
}

void ProblemAssembly::classifyContacts(const std::vector<char>* deferred, int threads) {
  const bool body_form = p.pack_body_form && p.dimension == 3;
  const bool compact_spheres = body_form && p.compact_spheres;
  const int m = static_cast<int>(cdata.contacts.size());
  ws.row_kind.resize(m);
  ws.row_minv_entries.resize(m);
  parallelFor(m, threads, [&](int c) {
    const Contact& contact = cdata.contacts[c];
    char kind = kNoRow;
    int minv_entries = 0;
    // index set: VEL takes closed contacts only; the gap-aware laws take every candidate
    if ((law == NormalLaw::Vel && !closedForVel(cmodel, cdata, c)) ||
        (deferred != nullptr && (*deferred)[c])) {
    } else if (body_form && rowInBodyForm(model, data, cmodel, contact, ws)) {
      kind = compact_spheres && sphereRowFits(contact, ws) ? kSphereRow : kBodyFormRow;
    } else {
      std::vector<int>& touched = ws.thread_touched[omp_get_thread_num()];
      const bool diagonal_row =
          entryComponents(&J.dof[J.begin[c]], J.begin[c + 1] - J.begin[c], touched);
      bool small = touched.size() <= 2;
      for (int comp : touched) small = small && model.components[comp].nv <= 6;
      kind = !small ? kSerialRow : diagonal_row ? kDiagonalRow : kEntryRow;
      if (!diagonal_row) minv_entries = minvEntries(touched);
    }
    ws.row_kind[c] = kind;
    ws.row_minv_entries[c] = minv_entries;
  });
}

int ProblemAssembly::numberRows() {
  const int m = static_cast<int>(cdata.contacts.size());
  int rows = 0, entries = 0, minv_entries = 0, spheres = 0, body_forms = 0;
  for (int c = 0; c < m; ++c) rows += ws.row_kind[c] != kNoRow;
  sizeRows(rows);
  for (int c = 0, pc = 0; c < m; ++c) {
    const char kind = ws.row_kind[c];
    if (kind == kNoRow) continue;
    p.contact[pc] = c;
    p.row_sphere[pc] = kind == kSphereRow ? spheres++ : -1;
    p.row_body_form[pc] = kind == kBodyFormRow ? body_forms++ : -1;
    if (kind == kDiagonalRow || kind == kEntryRow || kind == kSerialRow)
      entries += J.begin[c + 1] - J.begin[c];
    minv_entries += ws.row_minv_entries[c];
    ++pc;
    p.begin[pc] = entries;
    p.minv_begin[pc] = minv_entries;
  }
  sizeEntries(entries, minv_entries);
  p.spheres3d.resize(spheres);
  p.bodies3d.resize(body_forms);
  p.direct_body_forms = body_forms;
  return rows;
}

void ProblemAssembly::appendJointLimits() {
  for (int l = 0; l < static_cast<int>(model.limits.size()); ++l) {
    const JointLimit& limit = model.limits[l];
    const double gap = limit.side * (q_m[limit.q_index] - limit.bound);
    double rate = std::abs(v_start[limit.v_index]);
    if (v_free) rate = std::max(rate, std::abs((*v_free)[limit.v_index]));
    const double reach = law == NormalLaw::Vel ? kClosedGap : 2.0 * tau * rate;
    if (gap > reach) continue;
    appendEntryRow(
        -1 - l, 1,
        [&](int first) {
          p.dof[first] = limit.v_index;
          p.h[first] = Vector3(limit.side, 0.0, 0.0);
          if (p.rolling) p.rolling_h[first] = Vector2::Zero();
        },
        Vector3::Zero(), gap, 0.0, 0.0);
  }
}

const ActuatorCommand* ProblemAssembly::commandedMotion(int constraint) const {
  if (commands == nullptr) return nullptr;
  for (std::size_t a = 0; a < model.actuators.size() && a < commands->size(); ++a)
    if (model.actuators[a].prescribed && model.actuators[a].constraint == constraint &&
        !std::isnan((*commands)[a].position))
      return &(*commands)[a];
  return nullptr;
}

void ProblemAssembly::appendConstraints() {
  const int limit_count = static_cast<int>(model.limits.size());
  for (int k = 0; k < static_cast<int>(model.constraints.size()); ++k) {
    const ConstraintFunction& f = model.constraints[k];
    double gap = f.gap(q_m);
    // A driven one, g(q, t) = gap(q) - drive(t): the row's known velocity asks
    //   W_N^T v_{k+1} = w + (drive(t_{k+1}) - gap(q_m) - tau w) / (2 tau),
    // w the drive's mean rate over the step: on a smooth motion w itself, and a drift from it
    // (a kink of the motion, the solve's tolerance) is gone two steps later. Correcting the
    // whole drift at once (1 / tau) would make the midpoint update ring: v_{k+1} = -v_k.
    Vector3 known = Vector3::Zero();
    if (f.drive) {
      const ActuatorCommand* command = commandedMotion(k);
      auto drive = [&](double at) {
        if (command == nullptr) return f.drive(at);
        const double velocity = std::isnan(command->velocity) ? 0.0 : command->velocity;
        return command->position + velocity * (at - command->time);
      };
      if (position_level) {
        gap -= drive(t);
      } else {
        const double rate = (drive(t + tau) - drive(t - tau)) / (2.0 * tau);
        known.x() = -(rate + (drive(t + tau) - gap - tau * rate) / (2.0 * tau));
        gap = 0.0;
      }
    }
    const auto direction = [&](const std::function<VectorX(const VectorX&)>& of, const char* what) {
      VectorX w = of ? of(q_m) : VectorX::Zero(model.nv);
      if (w.size() != model.nv || !w.allFinite() || !std::isfinite(gap))
        throw std::runtime_error("constraint '" + f.name + "': its " + what +
                                 " must be finite with nv = " + std::to_string(model.nv) +
                                 " entries (and its gap finite)");
      return w;
    };
    const VectorX normal = direction(f.normal, "normal");
    double rate = std::abs(normal.dot(v_start));
    if (v_free) rate = std::max(rate, std::abs(normal.dot(*v_free)));
    const double reach = law == NormalLaw::Vel ? kClosedGap : 2.0 * tau * rate;
    if (gap > reach && !f.bilateral) continue;
    if (normal.isZero(0.0))
      throw std::runtime_error("constraint '" + f.name + "': its normal is zero at the gap " +
                               std::to_string(gap) + ": the constraint moves nothing");
    const VectorX tangent = direction(f.tangent, "tangent");
    const VectorX tangent2 =
        p.dimension == 3 ? direction(f.tangent2, "second tangent") : VectorX::Zero(model.nv);
    auto nonzero = [&](int j) {
      return normal[j] != 0.0 || tangent[j] != 0.0 || tangent2[j] != 0.0;
    };
    int count = 0;
    for (int j = 0; j < model.nv; ++j) count += nonzero(j);
    appendEntryRow(
        -1 - (limit_count + k), count,
        [&](int first) {
          for (int j = 0; j < model.nv; ++j) {
            if (!nonzero(j)) continue;
            p.dof[first] = j;
            p.h[first] = Vector3(normal[j], tangent[j], tangent2[j]);
            if (p.rolling) p.rolling_h[first] = Vector2::Zero();
            ++first;
          }
        },
        known, gap, f.friction, f.restitution);
    if (f.bilateral) {
      p.bilateral.resize(p.size(), 0);
      p.bilateral.back() = 1;
    }
  }
  if (!p.bilateral.empty()) p.bilateral.resize(p.size(), 0);
}

void ProblemAssembly::numberIslands(int threads) {
  const int n = p.size();
  if (n < kParallelItems) threads = 1;
  parallelFor(n, threads, [&](int c) {
    const std::array<int, 2>& moved = p.row_components[c];
    if (moved[0] >= 0 && moved[1] >= 0) join(moved[0], moved[1]);
  });
  // every row's root, once the joins are done
  ws.row_root.resize(n);
  parallelFor(n, threads, [&](int c) { ws.row_root[c] = root(ws.row_component[c]); });

  // islands numbered in order of their first row: deterministic
  std::fill(ws.island_of_root.begin(), ws.island_of_root.end(), -1);
  std::vector<int>& island_begin = p.island_begin;
  island_begin.assign(1, 0);
  int islands = 0;
  for (int c = 0; c < n; ++c) {
    int& id = ws.island_of_root[ws.row_root[c]];
    if (id < 0) {
      id = islands++;
      island_begin.push_back(0);
    }
    ++island_begin[id + 1];
  }
  for (int i = 0; i < islands; ++i) island_begin[i + 1] += island_begin[i];
  p.island_rows.resize(n);
  ws.touched.assign(island_begin.begin(), island_begin.end() - 1);  // fill cursors
  for (int c = 0; c < n; ++c) p.island_rows[ws.touched[ws.island_of_root[ws.row_root[c]]]++] = c;
}

void assembleContactProblem(const Model& model, const Data& data, const ContactModel& cmodel,
                            const ContactData& cdata, double t, NormalLaw law, double tau,
                            const VectorX& q_m, const VectorX& v_start, ContactProblem& p,
                            ContactProblemWorkspace& ws, const VectorX* v_free,
                            const std::vector<char>* deferred, int threads,
                            const std::vector<ActuatorCommand>* commands) {
  ProblemAssembly{model, data, cmodel, cdata, t, law, tau, q_m, v_start, p, ws, v_free, commands}
      .run(deferred, threads);
}

void assemblePositionProblem(const Model& model, const Data& data, const ContactModel& cmodel,
                             const ContactData& cdata, double t, const VectorX& q,
                             const VectorX& zero, ContactProblem& p, ContactProblemWorkspace& ws,
                             const std::vector<char>* left_out, int threads,
                             const std::vector<ActuatorCommand>* commands) {
  ProblemAssembly assembly{model, data, cmodel, cdata, t,       NormalLaw::Pos, 1.0,
                           q,     zero, p,      ws,    nullptr, commands};
  assembly.position_level = true;
  assembly.run(left_out, threads);
}

}  // namespace sweep
