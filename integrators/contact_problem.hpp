#pragma once
// The plain contact problem both schemes solve at q_m (the solvers see no bodies or shapes):
// for every contact c of the index set, its rows H_c = [W_N W_T] over v (sparse), the same
// rows premultiplied by M^-1 (sparse over the components the contact touches), the local
// Delassus block W_cc = H_c^T M^-1 H_c, the known relative velocity, gap, mu and e.
//
//   U_c = H_c^T v + known_c              local velocity (normal, tangent1, tangent2)
//   v   = v_free + sum_c (M^-1 H_c) P_c   velocity after the impulses P_c
#include <array>
#include <vector>

#include "framework/data.hpp"
#include "framework/enum_names.hpp"

namespace sweep {

struct ActuatorCommand;  // integrators/actuation.hpp

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
template <>
struct EnumNames<NormalLaw> {
  static constexpr EnumName<NormalLaw> table[] = {
      {NormalLaw::Vel, "vel"}, {NormalLaw::Iqs, "iqs"}, {NormalLaw::Pos, "pos"}};
};

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
  // per row, 1 for an equality U*_N = 0 with a normal impulse of either sign (a bilateral
  // constraint by functions); empty when there is none. Problems with such rows are not
  // packed: the solvers read them through the generic paths, which ask isBilateral.
  std::vector<char> bilateral;
  bool isBilateral(int c) const { return !bilateral.empty() && bilateral[c] != 0; }

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
  // the components (Model::components) each row moves: {a, -1} for one, {a, b} for two, and
  // {-2, -2} for more (a constraint by functions); the coloured sweeps read them
  std::vector<std::array<int, 2>> row_components;

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
    // first: all an open row that stays open reads (one cache line), see coulombUpdate
    // (contact_laws.hpp)
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
  // A row between two spheres, or a sphere and a body that does not move with the solve
  // (the world, a driven body), opted in by compact_spheres. Each moving side is a free
  // particle with one inverse inertia about every axis and only sphere shapes centred on its
  // origin, so the lever from its centre to the contact point is l n (l signed, |l| the
  // radius) and, with a = s R^T t1 and b = s R^T t2 (s the side's sign, R its rotation):
  //   U_N  = known_N + n.(v_a - v_b)
  //   U_T1 = known_1 + t1.(v_a - v_b) + l_a b_a.w_a + l_b b_b.w_b
  //   U_T2 = known_2 + t2.(v_a - v_b) - l_a a_a.w_a - l_b a_b.w_b
  //   U_R  = rolling_known + (a_a.w_a + a_b.w_b, b_a.w_a + b_b.w_b)
  // (n, t1, t2 signed for side a). W is then diagonal, diag(W_N, W_T, W_T) with
  // W_N = m_a^-1 + m_b^-1 and W_T = W_N + l_a^2 i_a^-1 + l_b^2 i_b^-1, and W_r is
  // (i_a^-1 + i_b^-1) I. The body-form row of the same contact stores all twelve coefficients
  // of each of its five rows and its 3x3 blocks: 704 bytes against these 320, which on the
  // wide powder bed stream from memory every sweep (docs/powder_bed.md). Its bits differ
  // from the body form's by round-off: the normal's zero lever terms are not summed, and the
  // off-diagonal terms of W are zero rather than a few ulps.
  struct alignas(64) PackedSphere3d {
    // first cache line: all an open row that stays open reads
    double known[3] = {};
    double bias = 0.0;
    double normal[3] = {};
    int dof_a = 0, dof_b = -1;  // first velocity of each side's six; -1: one moving side
    double tangent[2][3] = {};
    double mu = 0.0;
    double normal_inverse = 0.0;  // 1 / W_N
    double axes_a[2][3] = {};     // a_a, b_a
    double lever_a = 0.0, lever_b = 0.0;
    double axes_b[2][3] = {};  // a_b, b_b
    double inverse_mass_a = 0.0, inverse_mass_b = 0.0;
    double inverse_inertia_a = 0.0, inverse_inertia_b = 0.0;
    double tangent_inverse = 0.0;  // 1 / W_T
    double rolling_known[2] = {};
    double rolling_bound = 0.0;    // 0: no rolling row
    double rolling_inverse = 0.0;  // 1 / W_r(0, 0)
    double W_N() const { return inverse_mass_a + inverse_mass_b; }
    double W_T() const {
      return W_N() + lever_a * lever_a * inverse_inertia_a + lever_b * lever_b * inverse_inertia_b;
    }
    // the rolling velocity a unit tangential impulse makes: U_R += kappa (-dP_T2, dP_T1)
    double rollingCoupling() const {
      return inverse_inertia_a * lever_a + inverse_inertia_b * lever_b;
    }
    // The reads below are the sweeps' (inlined) and every other reader's: the generic
    // accessors of ContactProblem give the same bits.
    // v_a - v_b, or v_a alone
    [[gnu::always_inline]] void relativeLinear(const VectorX& v, double (&linear)[3]) const {
      const double* va = v.data() + dof_a;
      for (int i = 0; i < 3; ++i) linear[i] = va[i];
      if (dof_b < 0) return;
      const double* vb = v.data() + dof_b;
      for (int i = 0; i < 3; ++i) linear[i] -= vb[i];
    }
    [[gnu::always_inline]] double normalVelocity(const VectorX& v) const {
      double linear[3];
      relativeLinear(v, linear);
      return known[0] + normal[0] * linear[0] + normal[1] * linear[1] + normal[2] * linear[2];
    }
    // (U_c, U_r)
    [[gnu::always_inline]] void velocity(const VectorX& v, Vector3& u, Vector2& u_rolling) const {
      double linear[3];
      relativeLinear(v, linear);
      // (a.w, b.w) of one side, zero for a side that does not move
      auto turn = [&](int first, const double(&axes)[2][3], double(&out)[2])
          __attribute__((always_inline)) {
        out[0] = out[1] = 0.0;
        if (first < 0) return;
        const double* w = v.data() + first + 3;
        for (int j = 0; j < 2; ++j)
          out[j] = axes[j][0] * w[0] + axes[j][1] * w[1] + axes[j][2] * w[2];
      };
      double turn_a[2], turn_b[2];
      turn(dof_a, axes_a, turn_a);
      turn(dof_b, axes_b, turn_b);
      const double* frame[3] = {normal, tangent[0], tangent[1]};
      double along[3];
      for (int r = 0; r < 3; ++r)
        along[r] = frame[r][0] * linear[0] + frame[r][1] * linear[1] + frame[r][2] * linear[2];
      u.x() = known[0] + along[0];
      u.y() = known[1] + along[1] + lever_a * turn_a[1] + lever_b * turn_b[1];
      u.z() = known[2] + along[2] - lever_a * turn_a[0] - lever_b * turn_b[0];
      u_rolling.x() = rolling_known[0] + turn_a[0] + turn_b[0];
      u_rolling.y() = rolling_known[1] + turn_a[1] + turn_b[1];
    }
    // v += M^-1 (H_c dP + H_r dR)
    [[gnu::always_inline]] void apply(const Vector3& dP, const Vector2& dR, VectorX& v) const {
      double linear[3];
      for (int i = 0; i < 3; ++i)
        linear[i] = normal[i] * dP.x() + tangent[0][i] * dP.y() + tangent[1][i] * dP.z();
      auto side = [&](int first, double inverse_mass, double lever, const double(&axes)[2][3],
                      double inverse_inertia, double sign) __attribute__((always_inline)) {
        double* vs = v.data() + first;
        const double scaled = sign * inverse_mass;
        for (int i = 0; i < 3; ++i) vs[i] += scaled * linear[i];
        const double along1 = inverse_inertia * (dR.x() - lever * dP.z());
        const double along2 = inverse_inertia * (dR.y() + lever * dP.y());
        for (int i = 0; i < 3; ++i) vs[3 + i] += axes[0][i] * along1 + axes[1][i] * along2;
      };
      side(dof_a, inverse_mass_a, lever_a, axes_a, inverse_inertia_a, 1.0);
      if (dof_b >= 0) side(dof_b, inverse_mass_b, lever_b, axes_b, inverse_inertia_b, -1.0);
    }
  };
  std::vector<PackedRow3d> rows3d;
  std::vector<PackedEntry3d> h3d, minv3d;
  std::vector<PackedBodies3d> bodies3d;
  // set before the assembly: rows over spheres in the compact form above (3D; with
  // pack_body_form). Per row, row_sphere[c] is its record in spheres3d or -1; pack3d then
  // gives every row a slot: packed_slot[c] >= 0 its PackedRow3d in rows3d, < 0 its record
  // spheres3d[-1 - slot].
  bool compact_spheres = false;
  std::vector<PackedSphere3d> spheres3d;
  std::vector<int> row_sphere;
  std::vector<int> packed_slot;
  // the assembly's and pack3d's choice; false: every row in entry form (tests compare). Set it
  // before the assembly: a row the assembly wrote in body form has no entries to fall back on.
  bool pack_body_form = true;
  bool pack_rows =
      true;       // false: the assembly fills no rows2d / rows3d (SchemeSettings::packed_rows)
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
  int sphereForm(int c) const {
    return c < static_cast<int>(row_sphere.size()) ? row_sphere[c] : -1;
  }
  // a row the assembly wrote from its contact alone, without H entries
  bool hasNoEntries(int c) const { return bodyForm(c) >= 0 || sphereForm(c) >= 0; }
  // whether the packed rows (pack3d) cover every row
  bool packed3dComplete() const {
    return dimension == 3 && static_cast<int>(packed_slot.size()) == size();
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
    const int sphere = sphereForm(c);
    if (sphere >= 0) {
      forEachSphereEntry(spheres3d[sphere], visit);
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
  // the entries a compact sphere row stands for (see PackedSphere3d)
  template <class Visit>
  static void forEachSphereEntry(const PackedSphere3d& s, Visit&& visit) {
    auto side = [&](int first, double sign, double inverse_mass, double lever,
                    const double(&axes)[2][3], double inverse_inertia) {
      for (int i = 0; i < 3; ++i)
        visit(first + i,
              Vector3(sign * s.normal[i], sign * s.tangent[0][i], sign * s.tangent[1][i]),
              Vector2::Zero().eval(), inverse_mass);
      for (int i = 0; i < 3; ++i)
        visit(first + 3 + i, Vector3(0.0, lever * axes[1][i], -lever * axes[0][i]),
              Vector2(axes[0][i], axes[1][i]), inverse_inertia);
    };
    side(s.dof_a, 1.0, s.inverse_mass_a, s.lever_a, s.axes_a, s.inverse_inertia_a);
    if (s.dof_b >= 0)
      side(s.dof_b, -1.0, s.inverse_mass_b, s.lever_b, s.axes_b, s.inverse_inertia_b);
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
    if (sphereForm(c) >= 0) {
      Vector2 u_rolling;
      spheres3d[sphereForm(c)].velocity(v, u, u_rolling);
      return u;
    }
    if (hasNoEntries(c)) {
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
    if (sphereForm(c) >= 0) {
      spheres3d[sphereForm(c)].apply(dP, Vector2::Zero(), v);
      return;
    }
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
    if (sphereForm(c) >= 0) {
      Vector3 u_contact;
      spheres3d[sphereForm(c)].velocity(v, u_contact, u);
      return u;
    }
    if (hasNoEntries(c)) {
      forEachDiagonalEntry(
          c, [&](int k, const Vector3&, const Vector2& h_r, double) { u += h_r * v[k]; });
      return u;
    }
    for (int k = begin[c]; k < begin[c + 1]; ++k) u += rolling_h[k] * v[dof[k]];
    return u;
  }
  // v += M^-1 H_r,c dR
  void applyRolling(int c, const Vector2& dR, VectorX& v) const {
    if (sphereForm(c) >= 0) {
      spheres3d[sphereForm(c)].apply(Vector3::Zero(), dR, v);
      return;
    }
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
  std::vector<std::vector<int>> thread_touched;  // the same, per thread of the assembly
  std::vector<char> row_kind;                    // per detected contact: the row it makes, if any
  std::vector<int> row_minv_entries;             // per detected contact: its M^-1 H entries
  std::vector<int> row_component;                // islands: a component of each row
  std::vector<int> component_parent;             // islands: union-find over components
  std::vector<int> row_root;                     // islands: the root of each row's component
  std::vector<int> island_of_root;
  // A general row's scratch, one per thread of the assembly (the first serves the serial rows)
  struct EntryRowScratch {
    // per velocity index: its M^-1 H entry in the row being finished, -1 outside it. W_cc and
    // W_r then pair each H entry with its M^-1 H entry in one lookup instead of a double loop.
    std::vector<int> minv_slot;
    // H restricted to one component of at most 6 velocities, solved in place: no allocation
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 6, 5> rhs;
  };
  std::vector<EntryRowScratch> entry_scratch;
  // per body: a free particle, whose contacts the assembly writes straight in body form
  // (see rowInBodyForm); filled on first use from the constant inverse masses of the Data
  std::vector<char> free_particle;
  // per body: a free particle fit for PackedSphere3d rows (v_index >= 0), and what its rows
  // read of the body: 24 bytes instead of a Body record and a line of inverse masses, each a
  // cache miss per contact on a wide powder bed
  struct SphereParticle {
    int v_index = -1;  // -1: not such a particle
    int component = 0;
    double inverse_mass = 0.0;
    double inverse_inertia = 0.0;
  };
  std::vector<SphereParticle> sphere_particles;
};

// Whether assembleContactProblem writes the row of `contact` straight in body form from its
// frame and points, without Jacobian entries (3D; every moving side a free particle: the root
// floating joint of a body with a constant diagonal inverse mass, one translational inverse
// mass and the world's axes as its linear frame; the other side, if not moving, the world or a
// driven body). Its Jacobian rows are then not read: the stepper skips them.
bool rowInBodyForm(const Model& model, const Data& data, const ContactModel& cmodel,
                   const Contact& contact, ContactProblemWorkspace& workspace);
// The per-body part of rowInBodyForm, computed once (Data's constant inverses do not change)
// into workspace.free_particle and sphere_particles; rowInBodyForm calls it, and so must a
// caller before it asks rowInBodyForm from several threads.
void findFreeParticles(const Model& model, const Data& data, const ContactModel& cmodel,
                       ContactProblemWorkspace& workspace);

// A contact that touches exactly (a block placed on a floor) has a computed gap of +-1e-17 m
// from round-off; with the bare test gap <= 0, one of a block's two corners would leave the
// index set at random and the block would rock. Gaps up to this (1e-9 of the margin floor,
// 1e-12 of the smallest shape size) count as closed for the VEL law.
double touchingGap(const ContactModel& cmodel);
// A contact that carried a normal impulse at the last step stays closed for VEL up to this gap
// (1e-6 of the margin floor, 1e-9 of the smallest shape size): a solve stopped at its
// tolerance leaves a resting corner's gap at about +1e-12 m (a solve to 1e-6 leaves the
// velocities 1e-9 m/s off), and a corner dropped from the index set lets the body fall through
// it for a step (h^2 g). Contacts that did not push keep touchingGap: their impacts come at the
// same step as without it.
double heldGap(const ContactModel& cmodel);
// Whether VEL's index set takes detected contact `id` (cdata.held read where it is sized): a
// closed contact, or an adhesive one within its law's range (adhesionForce).
bool closedForVel(const ContactModel& cmodel, const ContactData& cdata, int id);
// The pull-off force of detected contact c (ContactLaw, adhesion): its law's F where the law is
// adhesive and the gap at q_m is at most its adhesion_range (or heldGap, so that a contact VEL
// holds closed is adhesive whatever the range), else 0.
double adhesionForce(const ContactModel& cmodel, const Contact& c);

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
// threads: the contacts' rows are written on that many threads from kParallelItems detected
// contacts on, each row with the arithmetic it has on one thread (the same bits for every
// count); rows over trees and general masses on one thread.
void assembleContactProblem(const Model& model, const Data& data, const ContactModel& cmodel,
                            const ContactData& cdata, double t, NormalLaw law, double tau,
                            const VectorX& q_m, const VectorX& v_start, ContactProblem& problem,
                            ContactProblemWorkspace& workspace, const VectorX* v_free = nullptr,
                            const std::vector<char>* deferred = nullptr, int threads = 1,
                            const std::vector<ActuatorCommand>* commands = nullptr);

// The rows of a position projection at q (integrators/position_projection.hpp): every detected
// contact, the violated joint limits and the constraints by functions, each a POS row on the
// displacement dq (zero: a zero vector of nv entries) with tau = 1, U_N(dq) + g(q) >= 0, no
// known velocity, a driven constraint at its drive's value at t; left_out as
// assembleContactProblem's `deferred`. Rows in the generic arrays (set p.pack_rows and
// p.pack_body_form false).
void assemblePositionProblem(const Model& model, const Data& data, const ContactModel& cmodel,
                             const ContactData& cdata, double t, const VectorX& q,
                             const VectorX& zero, ContactProblem& p, ContactProblemWorkspace& ws,
                             const std::vector<char>* left_out, int threads,
                             const std::vector<ActuatorCommand>* commands);

// The normal law's offset on U_N(k+1): U*_N = U_N(k+1) + normalBias(...) >= 0 for a contact
// in the index set, with u_start = U_N(k) and the gap at q_m.
double normalBias(NormalLaw law, double restitution, double u_start, double gap, double tau);

}  // namespace sweep
