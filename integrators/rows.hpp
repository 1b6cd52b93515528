#pragma once
// The contact problem's rows as the solvers read them. ContactProblem stores a row in one of
// several forms (contact_problem.hpp): entries (H, M^-1 H), packed 2D, packed 3D with entries
// or in body form, compact sphere rows. Each form has an adapter here with the same verbs
// (local velocity, normal velocity, apply an impulse, W and its inverse, bias, mu, rolling),
// and the laws (integrators/contact_laws.hpp) are written once over them. The reads must
// inline: they are the sweeps' hot path (docs/powder_bed.md).
#include "integrators/contact_problem.hpp"

namespace sweep {

// The packed 3D rows' storage, for the updates below
struct PackedRows3d {
  const ContactProblem::PackedRow3d* rows;
  const ContactProblem::PackedEntry3d* h;
  const ContactProblem::PackedEntry3d* minv;
  const ContactProblem::PackedBodies3d* bodies;
  const ContactProblem::PackedSphere3d* spheres;
  const int* slot;  // per row: its PackedRow3d (>= 0) or sphere record (-1 - index)
  explicit PackedRows3d(const ContactProblem& p)
      : rows(p.rows3d.data()),
        h(p.h3d.data()),
        minv(p.minv3d.data()),
        bodies(p.bodies3d.data()),
        spheres(p.spheres3d.data()),
        slot(p.packed_slot.data()) {}
};

// The three functions below read a row in body form in its entries' order (block a's linear
// then angular velocities, then block b's), and subtract where block b's coefficient is block
// a's negated: (-x) * y is -(x * y) exactly, so both forms give the same bits.

// U_N = H_N^T v + known_N alone
[[gnu::always_inline]] inline double packedNormalVelocity3d(const ContactProblem::PackedRow3d& r,
                                                            const PackedRows3d& s,
                                                            const VectorX& v) {
  double u = r.known.x();
  if (r.body_form < 0) {
    for (int k = r.begin; k < r.end; ++k) u += s.h[k].normal * v[s.h[k].dof];
    return u;
  }
  const ContactProblem::PackedBodies3d& b = s.bodies[r.body_form];
  const double* va = v.data() + b.dof_a;
  for (int i = 0; i < 3; ++i) u += b.translation_normal[i] * va[i];
  for (int i = 0; i < 3; ++i) u += b.rotation_normal_a[i] * va[3 + i];
  if (b.dof_b < 0) return u;
  const double* vb = v.data() + b.dof_b;
  for (int i = 0; i < 3; ++i) u -= b.translation_normal[i] * vb[i];
  for (int i = 0; i < 3; ++i) u += b.rotation_normal_b[i] * vb[3 + i];
  return u;
}

// (U_c, U_r) = H^T v + known on a packed 3D row: one pass over its entries
[[gnu::always_inline]] inline void packedVelocity3d(const ContactProblem::PackedRow3d& r,
                                                    const PackedRows3d& s, const VectorX& v,
                                                    Vector3& u, Vector2& u_rolling) {
  u = r.known;
  u_rolling = r.rolling_known;
  if (r.body_form < 0) {
    for (int k = r.begin; k < r.end; ++k) {
      const ContactProblem::PackedEntry3d& e = s.h[k];
      const double vk = v[e.dof];
      u.x() += e.normal * vk;
      u.y() += e.tangent1 * vk;
      u.z() += e.tangent2 * vk;
      u_rolling.x() += e.rolling1 * vk;
      u_rolling.y() += e.rolling2 * vk;
    }
    return;
  }
  const ContactProblem::PackedBodies3d& b = s.bodies[r.body_form];
  // inlined with `negated` a constant: the sweeps' hot path (docs/powder_bed.md)
  auto block = [&](const double* vblock, bool negated, const double(&rotation_normal)[3],
                   const double(&rotation)[4][3]) __attribute__((always_inline)) {
    for (int i = 0; i < 3; ++i) {
      const double vk = vblock[i];
      if (negated) {
        u.x() -= b.translation_normal[i] * vk;
        u.y() -= b.translation[0][i] * vk;
        u.z() -= b.translation[1][i] * vk;
      } else {
        u.x() += b.translation_normal[i] * vk;
        u.y() += b.translation[0][i] * vk;
        u.z() += b.translation[1][i] * vk;
      }
    }
    for (int i = 0; i < 3; ++i) {
      const double vk = vblock[3 + i];
      u.x() += rotation_normal[i] * vk;
      u.y() += rotation[0][i] * vk;
      u.z() += rotation[1][i] * vk;
      u_rolling.x() += rotation[2][i] * vk;
      u_rolling.y() += rotation[3][i] * vk;
    }
  };
  block(v.data() + b.dof_a, false, b.rotation_normal_a, b.rotation_a);
  if (b.dof_b >= 0) block(v.data() + b.dof_b, true, b.rotation_normal_b, b.rotation_b);
}

// v += M^-1 (H_c dP + H_r dR) on a packed 3D row
[[gnu::always_inline]] inline void applyPacked3d(const ContactProblem::PackedRow3d& r,
                                                 const PackedRows3d& s, const Vector3& dP,
                                                 const Vector2& dR, VectorX& v) {
  if (r.body_form >= 0) {
    const ContactProblem::PackedBodies3d& b = s.bodies[r.body_form];
    double translation[3];
    for (int i = 0; i < 3; ++i)
      translation[i] = b.translation_normal[i] * dP.x() + b.translation[0][i] * dP.y() +
                       b.translation[1][i] * dP.z();
    auto block = [&](double* vblock, double inverse_mass, bool negated,
                     const double(&rotation_normal)[3], const double(&rotation)[4][3],
                     const double(&inverse_inertia)[3]) __attribute__((always_inline)) {
      for (int i = 0; i < 3; ++i) {
        if (negated)
          vblock[i] -= inverse_mass * translation[i];
        else
          vblock[i] += inverse_mass * translation[i];
      }
      for (int i = 0; i < 3; ++i)
        vblock[3 + i] += inverse_inertia[i] * (rotation_normal[i] * dP.x() +
                                               rotation[0][i] * dP.y() + rotation[1][i] * dP.z() +
                                               rotation[2][i] * dR.x() + rotation[3][i] * dR.y());
    };
    block(v.data() + b.dof_a, b.inverse_mass_a, false, b.rotation_normal_a, b.rotation_a,
          b.inverse_inertia_a);
    if (b.dof_b >= 0)
      block(v.data() + b.dof_b, b.inverse_mass_b, true, b.rotation_normal_b, b.rotation_b,
            b.inverse_inertia_b);
    return;
  }
  if (r.minv_begin == r.minv_end) {  // a diagonal row: M^-1 H is H scaled
    for (int k = r.begin; k < r.end; ++k) {
      const ContactProblem::PackedEntry3d& e = s.h[k];
      v[e.dof] += e.inverse_mass * (e.normal * dP.x() + e.tangent1 * dP.y() + e.tangent2 * dP.z() +
                                    e.rolling1 * dR.x() + e.rolling2 * dR.y());
    }
    return;
  }
  for (int k = r.minv_begin; k < r.minv_end; ++k) {
    const ContactProblem::PackedEntry3d& e = s.minv[k];
    v[e.dof] += e.normal * dP.x() + e.tangent1 * dP.y() + e.tangent2 * dP.z() +
                e.rolling1 * dR.x() + e.rolling2 * dR.y();
  }
}

// (U_c, U_r) of row c, whichever packed form it has
[[gnu::always_inline]] inline void packedRowVelocity3d(const PackedRows3d& s, int c,
                                                       const VectorX& v, Vector3& u,
                                                       Vector2& u_rolling) {
  const int slot = s.slot[c];
  if (slot < 0)
    s.spheres[-1 - slot].velocity(v, u, u_rolling);
  else
    packedVelocity3d(s.rows[slot], s, v, u, u_rolling);
}

// Prefetches for update k of a sweep over compact sphere rows: the record of the row
// kSphereRecordAhead rows on, and the second sphere's velocity of the row kSphereVelocityAhead
// rows on, whose record is then in cache. The first sphere's velocities come in the rows'
// order, which the hardware prefetcher follows; the second's do not. On the wide powder bed
// the rows stream about a megabyte between two visits of one sphere, more than this core's
// L2, and the loads of v_b were the sweep's largest stall. The record's five lines are
// fetched as non-temporal: read once per sweep, they should not push v out of the caches
// (the sweeps' time fell by a sixth against a plain prefetch of its first line). No number
// changes.
constexpr int kSphereRecordAhead = 16, kSphereVelocityAhead = 8;
[[gnu::always_inline]] inline void prefetchSphereRow(const PackedRows3d& rows, const int* order,
                                                     int k, int n, const VectorX& v) {
  if (k + kSphereRecordAhead < n) {
    const int slot = rows.slot[order[k + kSphereRecordAhead]];
    if (slot < 0) {
      const char* record = reinterpret_cast<const char*>(&rows.spheres[-1 - slot]);
      for (int line = 0; line < 5; ++line) __builtin_prefetch(record + 64 * line, 0, 0);
    }
  }
  if (k + kSphereVelocityAhead < n) {
    const int slot = rows.slot[order[k + kSphereVelocityAhead]];
    if (slot < 0) {
      const int dof_b = rows.spheres[-1 - slot].dof_b;
      if (dof_b >= 0) {  // six velocities: one or two cache lines
        __builtin_prefetch(v.data() + dof_b);
        __builtin_prefetch(v.data() + dof_b + 5);
      }
    }
  }
}

// ---------------------------------------------------------------------------------------
// Row adapters: one per storage form, each with the same verbs. The laws
// (integrators/contact_laws.hpp) and the convex stage solvers read rows only through them.
//   dimension()                  2 or 3: the local size d
//   normalVelocity(v)            U_N = H_N^T v + known_N
//   normalVelocityChange(v)      H_N^T v
//   biasedNormalVelocity(v)      U_N + bias, stage 5a's U*_N
//   velocity(v, u, u_rolling)    U = H^T v + known (2D: third entry 0) and U_r = H_r^T v +
//                                known_r (rows without a rolling row: u_rolling as it was, or 0)
//   velocityChange(v, u, u_r)    H^T v and H_r^T v, without the known parts
//   freeVelocity(u, P)           U - W P, the local velocity without the row's own impulse
//   W(), W_inverse(), W_NN()     the local Delassus block, its inverse, its normal entry
//   normalInverse()              W^-1 (0, 0), the frictionless local solve
//   complianceInverse()          1 / W_NN, stage 5a's local solve
//   bias(), mu(), isBilateral()  the normal law's bias, friction, and an equality row
//   rollingBound()               mu_r R* (0: no rolling row), rollingW(), rollingKnown()
//   rollingChange(dP)            H_r^T M^-1 H_c dP (kFusedRolling rows)
//   apply(dP, dR, v)             v += M^-1 (H dP + H_r dR)
//   applyNormal(dP_N, v)         v += M^-1 W_N dP_N
// kSpatial: the row may be a 3D one (its W() is 3 x 3). kLocal: the size of the local vectors
// the laws compute in for it (Local = Eigen::Matrix<double, kLocal, 1>): 2 for packed 2D rows,
// whose arithmetic then stays in two lanes, 3 for the others (a 2D entry row's third is 0).
// kFusedRolling: the row reads and writes its rolling rows in the same pass as the contact's
// (packed 3D rows); entry rows apply the contact's impulse first and read the rolling
// velocity after it. Both are the same block Gauss-Seidel, equal up to round-off.

// Entry rows: the problem's generic arrays (H, M^-1 H, diagonal and body-form entries).
struct EntryRow {
  static constexpr bool kSpatial = true;
  static constexpr int kLocal = 3;
  static constexpr bool kFusedRolling = false;
  const ContactProblem& p;
  int c;
  int dimension() const { return p.dimension; }
  double normalVelocity(const VectorX& v) const { return p.localVelocity(c, v).x(); }
  double normalVelocityChange(const VectorX& v) const {
    return p.localVelocity(c, v).x() - p.known[c].x();
  }
  double biasedNormalVelocity(const VectorX& v) const { return normalVelocity(v) + bias(); }
  void velocity(const VectorX& v, Vector3& u, Vector2& u_rolling) const {
    u = p.localVelocity(c, v);
    if (rollingBound() > 0.0) u_rolling = p.rollingVelocity(c, v);
  }
  void velocityChange(const VectorX& v, Vector3& u, Vector2& u_rolling) const {
    u = p.localVelocity(c, v) - p.known[c];
    if (rollingBound() > 0.0) u_rolling = p.rollingVelocity(c, v) - p.rolling_known[c];
  }
  Vector2 rollingVelocity(const VectorX& v) const { return p.rollingVelocity(c, v); }
  // 1 / W_r(0, 0) where W_r is isotropic; entry rows take minimizeOnDisc's own test
  static constexpr double rollingIsotropicInverse() { return 0.0; }
  Vector3 freeVelocity(const Vector3& u, const Vector3& P) const { return u - p.delassus[c] * P; }
  const Matrix3& W() const { return p.delassus[c]; }
  const Matrix3& W_inverse() const { return p.delassus_inverse[c]; }
  double W_NN() const { return p.delassus[c](0, 0); }
  double normalInverse() const { return p.delassus_inverse[c](0, 0); }
  double complianceInverse() const { return p.normal_compliance_inverse[c]; }
  double bias() const { return p.normal_bias[c]; }
  double mu() const { return p.friction[c]; }
  bool isBilateral() const { return p.isBilateral(c); }
  double rollingBound() const { return p.rolling ? p.rolling_bound[c] : 0.0; }
  const Matrix2& rollingW() const { return p.rolling_delassus[c]; }
  void apply(const Vector3& dP, const Vector2& dR, VectorX& v) const {
    if (!dP.isZero(0.0)) p.applyImpulse(c, dP, v);
    if (!dR.isZero(0.0)) p.applyRolling(c, dR, v);
  }
  void applyNormal(double dP_N, VectorX& v) const { p.applyImpulse(c, Vector3(dP_N, 0, 0), v); }
};

// Packed 2D rows (ContactProblem::pack2d): no rolling rows, no equality rows.
struct Row2d {
  static constexpr bool kSpatial = false;
  static constexpr int kLocal = 2;
  static constexpr bool kFusedRolling = true;
  const ContactProblem::PackedRow2d& r;
  const ContactProblem::PackedEntry2d* h;
  const ContactProblem::PackedEntry2d* minv;
  static constexpr int dimension() { return 2; }
  [[gnu::always_inline]] double normalVelocity(const VectorX& v) const {
    double u = r.known.x();
    for (int k = r.begin; k < r.end; ++k) u += h[k].normal * v[h[k].dof];
    return u;
  }
  double normalVelocityChange(const VectorX& v) const { return sum(Vector2::Zero(), v).x(); }
  // U_N + bias summed from known_N + bias
  [[gnu::always_inline]] double biasedNormalVelocity(const VectorX& v) const {
    double u = r.known.x() + r.bias;
    for (int k = r.begin; k < r.end; ++k) u += h[k].normal * v[h[k].dof];
    return u;
  }
  [[gnu::always_inline]] Vector2 sum(Vector2 u, const VectorX& v) const {
    for (int k = r.begin; k < r.end; ++k) u += Vector2(h[k].normal, h[k].tangent) * v[h[k].dof];
    return u;
  }
  [[gnu::always_inline]] void velocity(const VectorX& v, Vector2& u, Vector2& u_rolling) const {
    u = sum(r.known, v);
    u_rolling.setZero();
  }
  void velocity(const VectorX& v, Vector3& u, Vector2& u_rolling) const {
    const Vector2 u2 = sum(r.known, v);
    u = Vector3(u2.x(), u2.y(), 0.0);
    u_rolling.setZero();
  }
  void velocityChange(const VectorX& v, Vector3& u, Vector2& u_rolling) const {
    const Vector2 u2 = sum(Vector2::Zero(), v);
    u = Vector3(u2.x(), u2.y(), 0.0);
    u_rolling.setZero();
  }
  [[gnu::always_inline]] Vector2 freeVelocity(const Vector2& u, const Vector2& P) const {
    return u - r.W * P;
  }
  const Matrix2& W() const { return r.W; }
  const Matrix2& W_inverse() const { return r.W_inverse; }
  double W_NN() const { return r.W(0, 0); }
  double normalInverse() const { return r.W_inverse(0, 0); }
  double complianceInverse() const { return r.normal_inverse; }
  double bias() const { return r.bias; }
  double mu() const { return r.mu; }
  static constexpr bool isBilateral() { return false; }
  static constexpr double rollingBound() { return 0.0; }
  Matrix2 rollingW() const { return Matrix2::Identity(); }
  Vector2 rollingChange(const Vector2&) const { return Vector2::Zero(); }
  Vector2 contactChange(const Vector2&) const { return Vector2::Zero(); }
  static constexpr double rollingIsotropicInverse() { return 0.0; }
  // dP: (normal, tangent), or a 3-vector whose third entry is ignored
  template <class Impulse>
  [[gnu::always_inline]] void apply(const Impulse& dP, const Vector2&, VectorX& v) const {
    for (int k = r.minv_begin; k < r.minv_end; ++k)
      v[minv[k].dof] += minv[k].normal * dP.x() + minv[k].tangent * dP.y();
  }
  [[gnu::always_inline]] void applyNormal(double dP_N, VectorX& v) const {
    for (int k = r.minv_begin; k < r.minv_end; ++k) v[minv[k].dof] += minv[k].normal * dP_N;
  }
};

// Packed 3D rows (ContactProblem::pack3d) with their entries or in body form.
struct GeneralRow3d {
  static constexpr bool kSpatial = true;
  static constexpr int kLocal = 3;
  static constexpr bool kFusedRolling = true;
  const ContactProblem::PackedRow3d& r;
  const PackedRows3d& s;
  static constexpr int dimension() { return 3; }
  double normalVelocity(const VectorX& v) const { return packedNormalVelocity3d(r, s, v); }
  double normalVelocityChange(const VectorX& v) const { return normalVelocity(v) - r.known.x(); }
  double biasedNormalVelocity(const VectorX& v) const { return normalVelocity(v) + r.bias; }
  void velocity(const VectorX& v, Vector3& u, Vector2& u_rolling) const {
    packedVelocity3d(r, s, v, u, u_rolling);
  }
  void velocityChange(const VectorX& v, Vector3& u, Vector2& u_rolling) const {
    packedVelocity3d(r, s, v, u, u_rolling);
    u -= r.known;
    u_rolling -= r.rolling_known;
  }
  Vector3 freeVelocity(const Vector3& u, const Vector3& P) const { return u - r.W * P; }
  const Matrix3& W() const { return r.W; }
  const Matrix3& W_inverse() const { return r.W_inverse; }
  double W_NN() const { return r.W(0, 0); }
  double normalInverse() const { return r.W_inverse(0, 0); }
  double complianceInverse() const { return 1.0 / r.W(0, 0); }  // as the assembly's
  double bias() const { return r.bias; }
  double mu() const { return r.mu; }
  static constexpr bool isBilateral() { return false; }
  double rollingBound() const { return r.rolling_bound; }
  Vector2 rollingChange(const Vector3& dP) const { return r.rolling_coupling * dP; }
  double rollingIsotropicInverse() const { return r.rolling_isotropic_inverse; }
  const Matrix2& rollingW() const { return r.rolling_W; }
  // the transpose of rollingChange: how a rolling impulse turns the contact's velocity
  Vector3 contactChange(const Vector2& dR) const { return r.rolling_coupling.transpose() * dR; }
  void apply(const Vector3& dP, const Vector2& dR, VectorX& v) const {
    applyPacked3d(r, s, dP, dR, v);
  }
  void applyNormal(double dP_N, VectorX& v) const {
    applyPacked3d(r, s, Vector3(dP_N, 0, 0), Vector2::Zero(), v);
  }
};

// Compact sphere rows (ContactProblem::PackedSphere3d): W and W_r diagonal.
struct SphereRow3d {
  static constexpr bool kSpatial = true;
  static constexpr int kLocal = 3;
  static constexpr bool kFusedRolling = true;
  const ContactProblem::PackedSphere3d& r;
  static constexpr int dimension() { return 3; }
  double normalVelocity(const VectorX& v) const { return r.normalVelocity(v); }
  double normalVelocityChange(const VectorX& v) const { return r.normalVelocity(v) - r.known[0]; }
  double biasedNormalVelocity(const VectorX& v) const { return r.normalVelocity(v) + r.bias; }
  void velocity(const VectorX& v, Vector3& u, Vector2& u_rolling) const {
    r.velocity(v, u, u_rolling);
  }
  void velocityChange(const VectorX& v, Vector3& u, Vector2& u_rolling) const {
    r.velocity(v, u, u_rolling);
    u -= Vector3(r.known[0], r.known[1], r.known[2]);
    u_rolling -= Vector2(r.rolling_known[0], r.rolling_known[1]);
  }
  Vector3 freeVelocity(const Vector3& u, const Vector3& P) const {
    const double W_T = r.W_T();
    return Vector3(u.x() - r.W_N() * P.x(), u.y() - W_T * P.y(), u.z() - W_T * P.z());
  }
  Matrix3 W() const { return Vector3(r.W_N(), r.W_T(), r.W_T()).asDiagonal(); }
  Matrix3 W_inverse() const {
    return Vector3(r.normal_inverse, r.tangent_inverse, r.tangent_inverse).asDiagonal();
  }
  double W_NN() const { return r.W_N(); }
  double normalInverse() const { return r.normal_inverse; }
  double complianceInverse() const { return r.normal_inverse; }
  double bias() const { return r.bias; }
  double mu() const { return r.mu; }
  static constexpr bool isBilateral() { return false; }
  double rollingBound() const { return r.rolling_bound; }
  Vector2 rollingChange(const Vector3& dP) const {
    const double kappa = r.rollingCoupling();
    return Vector2(-kappa * dP.z(), kappa * dP.y());
  }
  double rollingIsotropicInverse() const { return r.rolling_inverse; }
  Matrix2 rollingW() const {
    return Matrix2::Identity() * (r.inverse_inertia_a + r.inverse_inertia_b);
  }
  Vector3 contactChange(const Vector2& dR) const {
    const double kappa = r.rollingCoupling();
    return Vector3(0.0, kappa * dR.y(), -kappa * dR.x());
  }
  void apply(const Vector3& dP, const Vector2& dR, VectorX& v) const { r.apply(dP, dR, v); }
  void applyNormal(double dP_N, VectorX& v) const {
    r.apply(Vector3(dP_N, 0, 0), Vector2::Zero(), v);
  }
};

// The one place that decodes how a row is stored. A solver names the packed forms it reads
// (the others fall back to entry rows) and visits each row through the adapter of its form:
//   RowReader rows(problem, RowReader::kPacked2d | RowReader::kPacked3d);
//   rows.visit(c, [&](const auto& row) { ... });
class RowReader {
 public:
  enum Forms : unsigned {
    kEntries = 0,
    kPacked2d = 1,   // ContactProblem::rows2d, when every row has one
    kPacked3d = 2,   // ContactProblem::rows3d (entries or body form), when every row has one
    kSpheres3d = 4,  // compact sphere rows among them; without it, problems that have any
                     // are read as entry rows
  };
  RowReader(const ContactProblem& p, unsigned forms) : p_(p), packed3d_(p) {
    if ((forms & kPacked2d) && p.dimension == 2 && static_cast<int>(p.rows2d.size()) == p.size())
      form_ = Form::Packed2d;
    else if ((forms & kPacked3d) && p.packed3dComplete() &&
             ((forms & kSpheres3d) || p.spheres3d.empty()))
      form_ = Form::Packed3d;
  }
  bool packed() const { return form_ != Form::Entries; }
  bool packed3d() const { return form_ == Form::Packed3d; }
  const PackedRows3d& packedRows3d() const { return packed3d_; }

  // visit(k, row) for k in [first, last), row the adapter of row order[k]: the form decided
  // once for the loop, the sweeps' way (a packed 3D problem still tells sphere rows apart)
  template <class Visit>
  [[gnu::always_inline]] void forEach(const int* order, int first, int last, Visit&& f) const {
    if (form_ == Form::Packed2d) {
      const ContactProblem::PackedRow2d* rows = p_.rows2d.data();
      const ContactProblem::PackedEntry2d* h = p_.h2d.data();
      const ContactProblem::PackedEntry2d* minv = p_.minv2d.data();
      for (int k = first; k < last; ++k) f(k, Row2d{rows[order[k]], h, minv});
    } else if (form_ == Form::Packed3d) {
      for (int k = first; k < last; ++k) {
        const int slot = packed3d_.slot[order[k]];
        if (slot < 0)
          f(k, SphereRow3d{packed3d_.spheres[-1 - slot]});
        else
          f(k, GeneralRow3d{packed3d_.rows[slot], packed3d_});
      }
    } else {
      for (int k = first; k < last; ++k) f(k, EntryRow{p_, order[k]});
    }
  }

  template <class Visit>
  [[gnu::always_inline]] decltype(auto) visit(int c, Visit&& f) const {
    if (form_ == Form::Packed2d) return f(Row2d{p_.rows2d[c], p_.h2d.data(), p_.minv2d.data()});
    if (form_ == Form::Packed3d) {
      const int slot = packed3d_.slot[c];
      if (slot < 0) return f(SphereRow3d{packed3d_.spheres[-1 - slot]});
      return f(GeneralRow3d{packed3d_.rows[slot], packed3d_});
    }
    return f(EntryRow{p_, c});
  }

 private:
  enum class Form { Entries, Packed2d, Packed3d };
  const ContactProblem& p_;
  PackedRows3d packed3d_;
  Form form_ = Form::Entries;
};

}  // namespace sweep
