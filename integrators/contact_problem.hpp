#pragma once
// The plain contact problem both schemes solve at q_m (the solvers see no bodies or shapes):
// for every contact c of the index set, its rows H_c = [W_N W_T] over v (sparse), the same
// rows premultiplied by M^-1 (sparse over the components the contact touches), the local
// Delassus block W_cc = H_c^T M^-1 H_c, the known relative velocity, gap, mu and e.
//
//   U_c = H_c^T v + known_c              local velocity (normal, tangent1, tangent2)
//   v   = v_free + sum_c (M^-1 H_c) P_c   velocity after the impulses P_c
#include <vector>

#include "framework/data.hpp"

namespace sweep {

struct Contact;
struct ContactData;
struct ContactModel;

// Which detected contacts enter the solve, and the gap term of the normal law
// (docs/schemes.md, reference section 1.4).
enum class NormalLaw {
  Vel,  // Newton law on velocities; contacts with g(q_m) <= 0 (Moreau)
  Iqs,  // U_N + [g]_+ / tau >= 0 on every candidate (Jean's inelastic quasi-shock)
  Pos,  // U_N + g / tau >= 0 on every candidate: g(q_m) + h/2 U_N(k+1) >= 0
};
const char* normalLawName(NormalLaw law);

struct ContactProblem {
  int dimension = 2;  // local size d: 2 (normal, tangent) or 3
  // index of each row block in ContactData::contacts, or -1 - l for joint limit l
  std::vector<int> contact;

  std::vector<int> begin;  // H entries of contact c: [begin[c], begin[c + 1])
  std::vector<int> dof;
  std::vector<Vector3> h;       // (W_N, W_T1, W_T2) at dof
  std::vector<int> minv_begin;  // general rows only: see diagonal below
  std::vector<int> minv_dof;
  std::vector<Vector3> minv_h;  // (M^-1 W_N, M^-1 W_T1, M^-1 W_T2) at minv_dof
  // per H entry: the inverse mass at its dof when every body of the row has a constant
  // diagonal inverse mass (free spheres, bodies on their principal axes), so M^-1 H is that
  // entry scaled; 0 in the other rows. Such a diagonal row stores no M^-1 H entries
  // (minv_begin[c] == minv_begin[c + 1]): on a powder bed they were half the bytes that the
  // assembly wrote and a local update read. Rows read through the members below.
  std::vector<double> h_inverse_mass;
  std::vector<char> diagonal;  // per row: the case above (problems built by hand may omit it)
  // per row: its record in bodies3d when the assembly wrote it straight in body form, with no
  // H entries (begin[c] == begin[c + 1]), else -1; empty in problems built by hand. The
  // members below read such a row through its record, in the entries' order.
  std::vector<int> row_body_form;
  int direct_body_forms = 0;  // bodies3d[0, this) are those records; pack3d keeps them

  std::vector<Matrix3> delassus;                  // W_cc, d x d used
  std::vector<Matrix3> delassus_inverse;          // W_cc^-1 (d x d block; zero elsewhere)
  std::vector<double> normal_compliance_inverse;  // 1 / W_NN
  std::vector<Vector3> known;                     // relative velocity from driven bodies
  std::vector<double> gap, friction, restitution;
  std::vector<Vector3> velocity_start;  // U_c^k = H_c^T v_k + known_c
  std::vector<double> normal_bias;      // e U_N^k + gap term: U*_N = U_N + normal_bias

  // Rolling resistance (empty unless the scene has it): per row, the relative angular velocity
  // U_r = H_r^T v + rolling_known about the two tangents (3D) or z (2D, second entry zero),
  // H_r and M^-1 H_r aligned with h and minv_h, W_r = H_r^T M^-1 H_r, and the bound
  // |R_c| <= rolling_bound[c] * (normal impulse). Rows with bound 0 carry no rolling torque.
  bool rolling = false;
  std::vector<Vector2> rolling_h, rolling_minv_h, rolling_known;
  std::vector<Matrix2> rolling_delassus;
  std::vector<double> rolling_bound;

  // contact islands: rows that share no moving component never interact, and each island is
  // solved on its own (rows island_rows[island_begin[i] .. island_begin[i + 1]) ). Empty:
  // one island of every row.
  std::vector<int> island_begin;
  std::vector<int> island_rows;

  // 2D scenes: the same data packed per row, so that one local update reads two cache lines
  // of row data and one stream per row set (filled by pack2d(); empty in 3D)
  struct PackedRow2d {
    Matrix2 W;
    Matrix2 W_inverse;
    Vector2 known;
    double bias = 0.0;
    double mu = 0.0;
    double normal_inverse = 0.0;  // 1 / W_NN
    int begin = 0, end = 0, minv_begin = 0, minv_end = 0;
  };
  struct PackedEntry2d {
    double normal = 0.0, tangent = 0.0;
    int dof = 0;
  };
  std::vector<PackedRow2d> rows2d;
  std::vector<PackedEntry2d> h2d, minv2d;
  void pack2d();  // from the arrays above; call after changing them (none with rolling rows)

  // 3D scenes, scheme A: the same packing with the rolling rows folded in, so that one update
  // reads H once and writes v once for the contact and its rolling rows together (the rolling
  // velocity after the contact's own update is U_r + rolling_coupling dP). Filled by pack3d().
  struct PackedRow3d {
    // first: all an open row that stays open reads (one cache line), see coulombUpdate3d
    Vector3 known;
    double bias = 0.0;
    // a diagonal row (see h_inverse_mass) has no M^-1 H entries: minv_begin == minv_end, and
    // v is updated through its H entries. On the powder bed this halves the bytes a local
    // update reads (their weight in the sweep time: docs/powder_bed.md, "Rows in body form").
    int begin = 0, end = 0, minv_begin = 0, minv_end = 0;
    // >= 0: the row is in body form, bodies3d[body_form], and has no entries in h3d
    int body_form = -1;
    Matrix3 W;
    Matrix3 W_inverse;
    double mu = 0.0;
    Eigen::Matrix<double, 2, 3> rolling_coupling = Eigen::Matrix<double, 2, 3>::Zero();
    Matrix2 rolling_W = Matrix2::Identity();
    Vector2 rolling_known = Vector2::Zero();
    double rolling_bound = 0.0;  // 0: no rolling row
    // 1 / W_r(0, 0) when W_r is a multiple of the identity (spheres), else 0: the disc
    // projection is then Euclidean and closed-form
    double rolling_isotropic_inverse = 0.0;
  };
  struct PackedEntry3d {
    double normal = 0.0, tangent1 = 0.0, tangent2 = 0.0, rolling1 = 0.0, rolling2 = 0.0;
    double inverse_mass = 0.0;  // of a diagonal row's H entry
    int dof = 0;
  };
  // A diagonal row over one or two blocks of six consecutive velocities whose first three
  // carry no rolling and one inverse mass (free bodies: linear then angular velocity, as the
  // floating joint orders them), where the second block's first three coefficients are the
  // first's negated (the relative velocity of two bodies in one world frame). pack3d checks
  // each of these to the bit and keeps the entry form otherwise. Sphere pairs are such rows:
  // 384 bytes against 12 entries of 56, and the normal coefficients an open row reads share
  // two cache lines instead of spreading over ten. Sums run in the entries' order, so a row
  // gives the same bits in either form.
  struct alignas(64) PackedBodies3d {
    double translation_normal[3] = {};  // block a's; block b's are their negatives
    double rotation_normal_a[3] = {}, rotation_normal_b[3] = {};
    int dof_a = 0, dof_b = -1;      // first velocity of each block; -1: one block
    double translation[2][3] = {};  // tangent1, tangent2 coefficients of block a
    double rotation_a[4][3] = {}, rotation_b[4][3] = {};  // tangent1, tangent2, rolling1, rolling2
    double inverse_mass_a = 0.0, inverse_mass_b = 0.0;
    double inverse_inertia_a[3] = {}, inverse_inertia_b[3] = {};
  };
  std::vector<PackedRow3d> rows3d;
  std::vector<PackedEntry3d> h3d, minv3d;
  std::vector<PackedBodies3d> bodies3d;
  // the assembly's and pack3d's choice; false: every row in entry form (tests compare). Set it
  // before the assembly: a row the assembly wrote in body form has no entries to fall back on.
  bool pack_body_form = true;
  void pack3d();  // from the arrays above; call after changing them
  // pack3d's lookup from a velocity index to the row's M^-1 H entry (-1 between rows), grown
  // to the largest index seen
  std::vector<int> pack_minv_slot;

  int size() const { return static_cast<int>(contact.size()); }
  int islandCount() const {
    return island_begin.empty() ? 1 : static_cast<int>(island_begin.size()) - 1;
  }

  int bodyForm(int c) const {
    return c < static_cast<int>(row_body_form.size()) ? row_body_form[c] : -1;
  }
  // visit(dof, h, h_rolling, inverse_mass) for each H entry of row c, in order: the stored
  // entries of a diagonal row, or those a row in body form stands for
  template <class Visit>
  void forEachDiagonalEntry(int c, Visit&& visit) const {
    const int form = bodyForm(c);
    if (form >= 0) {
      forEachBodyFormEntry(bodies3d[form], visit);
      return;
    }
    for (int k = begin[c]; k < begin[c + 1]; ++k)
      visit(dof[k], h[k], rolling ? rolling_h[k] : Vector2::Zero().eval(), h_inverse_mass[k]);
  }
  template <class Visit>
  static void forEachBodyFormEntry(const PackedBodies3d& b, Visit&& visit) {
    auto block = [&](int first, double sign, double inverse_mass, const double(&rotation_normal)[3],
                     const double(&rotation)[4][3], const double(&inverse_inertia)[3]) {
      for (int i = 0; i < 3; ++i)
        visit(first + i,
              Vector3(sign * b.translation_normal[i], sign * b.translation[0][i],
                      sign * b.translation[1][i]),
              Vector2::Zero().eval(), inverse_mass);
      for (int i = 0; i < 3; ++i)
        visit(first + 3 + i, Vector3(rotation_normal[i], rotation[0][i], rotation[1][i]),
              Vector2(rotation[2][i], rotation[3][i]), inverse_inertia[i]);
    };
    block(b.dof_a, 1.0, b.inverse_mass_a, b.rotation_normal_a, b.rotation_a, b.inverse_inertia_a);
    if (b.dof_b >= 0)
      block(b.dof_b, -1.0, b.inverse_mass_b, b.rotation_normal_b, b.rotation_b,
            b.inverse_inertia_b);
  }
  // visit(dof) for each velocity row c's impulse moves
  template <class Visit>
  void forEachMovedDof(int c, Visit&& visit) const {
    if (isDiagonal(c))
      forEachDiagonalEntry(c, [&](int k, const Vector3&, const Vector2&, double) { visit(k); });
    for (int k = minv_begin[c]; k < minv_begin[c + 1]; ++k) visit(minv_dof[k]);
  }

  Vector3 localVelocity(int c, const VectorX& v) const {
    Vector3 u = known[c];
    if (bodyForm(c) >= 0) {
      forEachDiagonalEntry(
          c, [&](int k, const Vector3& h_k, const Vector2&, double) { u += h_k * v[k]; });
      return u;
    }
    for (int k = begin[c]; k < begin[c + 1]; ++k) u += h[k] * v[dof[k]];
    return u;
  }
  bool isDiagonal(int c) const { return c < static_cast<int>(diagonal.size()) && diagonal[c]; }
  // v += M^-1 H_c dP
  void applyImpulse(int c, const Vector3& dP, VectorX& v) const {
    if (isDiagonal(c)) {
      forEachDiagonalEntry(c, [&](int k, const Vector3& h_k, const Vector2&, double inverse_mass) {
        v[k] += inverse_mass * h_k.dot(dP);
      });
      return;
    }
    for (int k = minv_begin[c]; k < minv_begin[c + 1]; ++k) v[minv_dof[k]] += minv_h[k].dot(dP);
  }
  Vector2 rollingVelocity(int c, const VectorX& v) const {
    Vector2 u = rolling_known[c];
    if (bodyForm(c) >= 0) {
      forEachDiagonalEntry(
          c, [&](int k, const Vector3&, const Vector2& h_r, double) { u += h_r * v[k]; });
      return u;
    }
    for (int k = begin[c]; k < begin[c + 1]; ++k) u += rolling_h[k] * v[dof[k]];
    return u;
  }
  // v += M^-1 H_r,c dR
  void applyRolling(int c, const Vector2& dR, VectorX& v) const {
    if (isDiagonal(c)) {
      forEachDiagonalEntry(c, [&](int k, const Vector3&, const Vector2& h_r, double inverse_mass) {
        v[k] += inverse_mass * h_r.dot(dR);
      });
      return;
    }
    for (int k = minv_begin[c]; k < minv_begin[c + 1]; ++k)
      v[minv_dof[k]] += rolling_minv_h[k].dot(dR);
  }
};

// Workspace of the assembly, sized from the model.
struct ContactProblemWorkspace {
  explicit ContactProblemWorkspace(const Model& model);
  std::vector<MatrixX> component_rhs;  // per component: nv x 3 block of H restricted to it
  std::vector<int> dof_component;      // component of each velocity index
  std::vector<int> touched;            // components of the current contact
  std::vector<int> row_component;      // islands: a component of each row
  std::vector<int> component_parent;   // islands: union-find over components
  std::vector<int> island_of_root;
  // per velocity index: its M^-1 H entry in the row being finished, -1 outside it. W_cc and
  // W_r then pair each H entry with its M^-1 H entry in one lookup instead of a double loop.
  std::vector<int> minv_slot;
  // per body: a free particle, whose contacts the assembly writes straight in body form
  // (see rowInBodyForm); filled on first use from the constant inverse masses of the Data
  std::vector<char> free_particle;
};

// Whether assembleContactProblem writes the row of `contact` straight in body form from its
// frame and points, without Jacobian entries (3D; every moving side a free particle: the root
// floating joint of a body with a constant diagonal inverse mass, one translational inverse
// mass and the world's axes as its linear frame; the other side, if not moving, the world or a
// driven body). Its Jacobian rows are then not read: the stepper skips them.
bool rowInBodyForm(const Model& model, const Data& data, const ContactModel& cmodel,
                   const Contact& contact, ContactProblemWorkspace& workspace);

// A contact that touches exactly (a block placed on a floor) has a computed gap of +-1e-17 m
// from round-off; with the bare test gap <= 0, one of a block's two corners would leave the
// index set at random and the block would rock. Gaps up to this (1e-9 of the margin floor,
// 1e-12 of the smallest shape size) count as closed for the VEL law.
double touchingGap(const ContactModel& cmodel);

// Builds the problem from cdata.contacts/jacobian (assembled at q_m and time t) and the
// factored mass blocks of data (at q_m); rows in body form (rowInBodyForm) from the contacts
// alone, with the driven bodies' motion at t. tau = h/2 is the time over which a gap closes
// (midpoint scheme).
// Joint limits (Model::limits) join the same solve as frictionless unilateral rows with gap
// side (q_m - bound); with the gap-aware laws a limit enters once it can close within the
// step: gap <= 2 tau |joint rate|, the rate taken at the start of the step and, when given,
// in v_free (a joint that gravity or the applied forces accelerate into its limit during the
// step would otherwise pass it unseen).
// deferred (when given, one flag per detected contact): contacts left out of this problem;
// candidate screening (time_stepper.hpp) solves without them and checks them afterwards.
void assembleContactProblem(const Model& model, const Data& data, const ContactModel& cmodel,
                            const ContactData& cdata, double t, NormalLaw law, double tau,
                            const VectorX& q_m, const VectorX& v_start, ContactProblem& problem,
                            ContactProblemWorkspace& workspace, const VectorX* v_free = nullptr,
                            const std::vector<char>* deferred = nullptr);

// The normal law's offset on U_N(k+1): U*_N = U_N(k+1) + normalBias(...) >= 0 for a contact
// in the index set, with u_start = U_N(k) and the gap at q_m.
double normalBias(NormalLaw law, double restitution, double u_start, double gap, double tau);

}  // namespace sweep
