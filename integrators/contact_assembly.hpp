#pragma once
// The assembly of the contact problem (assembleContactProblem, contact_problem.hpp), one step
// a member: what row each contact makes, the rows written (from Jacobian entries, in body
// form or as compact sphere rows; contact_row_writers.cpp), joint limits and constraints by
// functions appended, islands and the packed forms (contact_assembly.cpp). Internal to
// integrators/.
#include <vector>

#include "contact/detection.hpp"
#include "integrators/actuation.hpp"
#include "integrators/contact_problem.hpp"

namespace sweep {

struct ProblemAssembly {
  // kEntryRow: a general row over at most two components of at most 6 velocities each, written
  // on threads; kSerialRow: the others (a tree's rows), written on one thread
  enum RowKind : char { kNoRow, kSphereRow, kBodyFormRow, kDiagonalRow, kEntryRow, kSerialRow };

  const Model& model;
  const Data& data;
  const ContactModel& cmodel;
  const ContactData& cdata;
  double t;
  NormalLaw law;
  double tau;
  const VectorX& q_m;
  const VectorX& v_start;
  ContactProblem& p;
  ContactProblemWorkspace& ws;
  const VectorX* v_free;
  // Python's commands by actuator (null: none): a prescribed joint's commanded motion replaces
  // its constraint's drive (integrators/actuation.hpp)
  const std::vector<ActuatorCommand>* commands = nullptr;
  // rows of a position projection (integrators/position_projection.hpp): no known velocities
  // (driven bodies hold still), and a driven constraint's row asks gap(q) = drive(t)
  bool position_level = false;
  const ContactJacobian& J = cdata.jacobian;
  int rhs_columns = cdata.jacobian.rolling ? 5 : 3;

  void run(const std::vector<char>* deferred, int threads);

  // Per-row and per-entry arrays are sized once the rows are counted, and every element is
  // then written (rows on several threads, each at its own place): nothing is cleared.
  void sizeRows(int rows);
  void sizeEntries(int entries, int minv_entries);

  // islands: union-find over the components, a row's components joined
  int root(int c);
  void join(int first, int second);
  void joinComponents(const std::vector<int>& touched);

  // The components that entries [first, first + count) of dofs move, in order of first
  // appearance, into touched; returns whether every entry's dof has a diagonal constant
  // inverse mass (> 0 exactly there), the case where M^-1 H is H scaled.
  bool entryComponents(const int* dofs, int count, std::vector<int>& touched);

  // how many M^-1 H entries a general row over these components stores
  int minvEntries(const std::vector<int>& touched);

  // The contacts' rows in three passes: what row each contact makes (threads), the rows
  // numbered in contact order with their places in the arrays, then the rows written, each
  // at its place (threads; general rows, which share scratch, on one thread). Each row's
  // arithmetic is the same on any thread: the problem has the same bits for every count.
  void writeContactRows(const std::vector<char>* deferred, int threads);

  // What row each detected contact makes (ws.row_kind) and how many M^-1 H entries it stores
  void classifyContacts(const std::vector<char>* deferred, int threads);

  // The rows numbered in contact order, with their places in the arrays; returns their count
  int numberRows();

  // joint limits: gap = side (q - bound) >= 0, W_N = side on the joint's velocity
  void appendJointLimits();

  // constraints by functions (Model::constraints): gap, normal and tangents at q_m
  void appendConstraints();
  // the command that replaces constraint k's drive, or null
  const ActuatorCommand* commandedMotion(int constraint) const;

  // the rows of two components or fewer joined (the others were, as they were made; on
  // threads from kParallelItems rows), then islands numbered in order of their first row:
  // deterministic
  void numberIslands(int threads);

  // one row block: H entries already pushed; computes M^-1 H, W_cc, velocities and bias
  // W_cc = H^T M^-1 H and W_r of a diagonal row (M^-1 H is H scaled), summed over its
  // entries in order, stored or in body form alike. Plain arrays: Eigen's outer products went
  // through the stack, and the stores stalled the loads of the next entry (the same products
  // in the same order, so the same bits).
  void diagonalDelassus(int pc, Matrix3& W, Matrix2& W_r);

  // the rest of row pc once its W_cc and W_r are known: its components, inverse, velocities
  // and bias (touched holds the components of the row; islands are joined afterwards)
  // diagonal_W: W is diagonal by construction (PackedSphere3d), and so is its inverse
  void finishRowTail(int pc, const std::vector<int>& touched, Matrix3 W, Matrix2 W_r,
                     const Vector3& known, double gap, double mu, double e,
                     const Vector2& known_spin, double rolling_bound, bool diagonal_W = false);

  // Row pc from its H entries (written at [begin[pc], begin[pc + 1])): M^-1 H at
  // [minv_begin[pc], minv_begin[pc + 1]) unless the row is diagonal, W_cc, then the rest.
  // A general row uses `scratch` (its thread's), and over a component of more than 6
  // velocities the per-component scratch of ws: one thread only.
  void finishEntryRow(int pc, const std::vector<int>& touched, bool diagonal_row,
                      const Vector3& known, double gap, double mu, double e,
                      const Vector2& known_spin, double rolling_bound,
                      ContactProblemWorkspace::EntryRowScratch& scratch);

  // A row over free particles, written straight in body form from the contact's frame and
  // points (rowInBodyForm): the Jacobian's columns of a free body with the arithmetic of
  // assembleContactJacobian, W_cc and W_r over the entries the record stands for in their
  // order, so the row has the bits of one assembled from entries and packed by pack3d. On a
  // powder bed this skips three copies of every row (Jacobian, H entries, packing).
  void bodyFormRow(int pc, const Contact& contact, std::vector<int>& touched);

  // A row over spheres in compact form (ContactProblem::PackedSphere3d): the frame, each
  // side's signed lever along the normal and its axes R^T t1, R^T t2, written in place.
  void sphereRow(int pc, const Contact& contact, std::vector<int>& touched);

  // A contact's row from its Jacobian entries
  void contactEntryRow(int pc, int c, std::vector<int>& touched,
                       ContactProblemWorkspace::EntryRowScratch& scratch);

  // The two sides of a contact written from its frame and points: a driven side adds its
  // motion at t to known and spin; visit(body, point, sign) for each dynamic side, with sign
  // -1 on side a and +1 on side b
  template <class Visit>
  void forEachSide(const Contact& contact, Vector3& known, Vector2& spin, Visit&& visit) {
    for (int side = 0; side < 2; ++side) {
      const BodyRef& ref = side == 0 ? contact.body_a : contact.body_b;
      const Vector3& point = side == 0 ? contact.point_a : contact.point_b;
      const double sign = side == 0 ? -1.0 : 1.0;
      if (ref.kind == BodyRef::Kind::Driven)
        addDrivenVelocity(model.driven_bodies[ref.index], contact, point, contact.tangent1,
                          contact.tangent2, sign, t, known, spin);
      else if (ref.kind == BodyRef::Kind::Dynamic)
        visit(ref.index, point, sign);
    }
  }

  // a row appended after the contacts' rows, on one thread: entries(first) writes its H
  // entries at [first, first + count)
  template <class Entries>
  void appendEntryRow(int id, int count, Entries&& writeEntries, const Vector3& known, double gap,
                      double mu, double e) {
    const int pc = p.size();
    sizeRows(pc + 1);
    p.contact[pc] = id;
    const int first = static_cast<int>(p.dof.size());
    p.begin[pc + 1] = first + count;
    sizeEntries(first + count, static_cast<int>(p.minv_dof.size()));
    writeEntries(first);
    const bool diagonal_row = entryComponents(&p.dof[first], count, ws.touched);
    const int minv_first = static_cast<int>(p.minv_dof.size());
    p.minv_begin[pc + 1] = minv_first + (diagonal_row ? 0 : minvEntries(ws.touched));
    sizeEntries(first + count, p.minv_begin[pc + 1]);
    finishEntryRow(pc, ws.touched, diagonal_row, known, gap, mu, e, Vector2::Zero(), 0.0,
                   ws.entry_scratch[0]);
    joinComponents(ws.touched);
  }
};

}  // namespace sweep
