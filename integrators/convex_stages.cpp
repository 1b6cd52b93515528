#include "integrators/convex_stages.hpp"

#include <algorithm>
#include <cmath>

#include "framework/parallel.hpp"
#include "integrators/projected_newton.hpp"
#include "integrators/rows.hpp"
#include "integrators/sweeps.hpp"

namespace sweep {

namespace {

SolverStats statsOf(const MprgpStats& solve, int rows) {
  SolverStats stats;
  stats.iterations = solve.iterations;
  stats.updates = static_cast<long>(solve.products) * rows;
  stats.residual = solve.residual;
  stats.status = solve.converged ? SolverStatus::Converged : SolverStatus::MaxIterations;
  return stats;
}

MprgpSettings mprgpSettings(const SolverSettings& settings) {
  MprgpSettings s;
  s.max_iterations = settings.max_iterations;
  s.tolerance = settings.tolerance;
  s.threads = settings.threads;
  return s;
}

// Appends the column of a variable whose unit value is the impulse (dP, dR) on row c:
// H_c (dP, dR) to J and M^-1 H_c (dP, dR) to K (QpOperator::columns).
void appendColumn(const ContactProblem& p, int c, const Vector3& dP, const Vector2& dR,
                  SparseColumns& J, SparseColumns& K) {
  const bool rolling = p.rolling && !dR.isZero(0.0);
  if (p.isDiagonal(c) || p.hasNoEntries(c)) {
    p.forEachDiagonalEntry(c, [&](int k, const Vector3& h, const Vector2& h_r, double im) {
      const double s = h.dot(dP) + (rolling ? h_r.dot(dR) : 0.0);
      if (s == 0.0) return;
      J.push(k, s);
      K.push(k, im * s);
    });
  } else {
    for (int e = p.begin[c]; e < p.begin[c + 1]; ++e) {
      const double s = p.h[e].dot(dP) + (rolling ? p.rolling_h[e].dot(dR) : 0.0);
      if (s != 0.0) J.push(p.dof[e], s);
    }
    for (int e = p.minv_begin[c]; e < p.minv_begin[c + 1]; ++e) {
      const double s = p.minv_h[e].dot(dP) + (rolling ? p.rolling_minv_h[e].dot(dR) : 0.0);
      if (s != 0.0) K.push(p.minv_dof[e], s);
    }
  }
  J.endColumn();
  K.endColumn();
}

// How a product visits the rows. M^-1 H x adds each row's image into velocities that rows
// share: from parallel_rows rows on it goes by the coloured sweeps' chunks
// (integrators/sweeps.hpp), colour after colour, so that each velocity sums its rows in an order
// the colouring fixes, whatever the thread count. H^T v writes each row's own variables: any split.
class RowSchedule {
 public:
  RowSchedule(const ContactProblem& p, const SolverSettings& settings, SolverWorkspace& ws)
      : ws_(ws), rows_(p.size()), threads_(settings.threads) {
    const std::size_t n = p.size();
    coloured_ = rows_ >= settings.parallel_rows && p.row_components.size() == n &&
                ws.row_colour.size() >= n && ws.order.size() >= n;
    if (!coloured_) return;
    for (int c = 0; c < rows_; ++c) ws.order[c] = c;
    colourIsland(p, ws, rows_);
  }
  template <class Visit>
  void scatter(Visit&& visit) const {
    if (!coloured_) {
      for (int c = 0; c < rows_; ++c) visit(c);
      return;
    }
    forEachColourChunk(ws_, threads_, [&](int chunk) {
      for (int k = ws_.chunk_begin[chunk]; k < ws_.chunk_begin[chunk + 1]; ++k) visit(ws_.order[k]);
    });
  }
  template <class Visit>
  void gather(Visit&& visit) const {
    forEachIndex(rows_, threads_, visit);
  }
  int threads() const { return threads_; }

 private:
  const SolverWorkspace& ws_;
  int rows_, threads_;
  bool coloured_ = false;
};

// Normal rows only: variable normal_var[c] (-1: none) is s_c lambda_c; the gradient is
// (U_N(v) - target_c) / s_c.
class NormalRows final : public QpOperator {
 public:
  NormalRows(const ContactProblem& p, const SolverWorkspace::Convex& ws,
             const RowSchedule& schedule)
      : p_(p),
        ws_(ws),
        schedule_(schedule),
        rows_(p, RowReader::kPacked2d | RowReader::kPacked3d | RowReader::kSpheres3d) {}
  void toVelocity(const std::vector<double>& x, VectorX& z) const override {
    clearVelocities(&ws_.dofs, z, schedule_.threads());
    schedule_.scatter([&](int c) {
      const int k = ws_.normal_var[c];
      if (k < 0 || x[k] == 0.0) return;
      const double impulse = x[k] * ws_.normal_scale[c];
      rows_.visit(
          c, [&](const auto& row) { row.apply(Vector3(impulse, 0.0, 0.0), Vector2::Zero(), z); });
    });
  }
  void toGradient(const VectorX& v, bool affine, std::vector<double>& y) const override {
    schedule_.gather([&](int c) {
      const int k = ws_.normal_var[c];
      if (k < 0) return;
      rows_.visit(c, [&](const auto& row) {
        y[k] = ws_.normal_scale[c] *
               (affine ? row.normalVelocity(v) - ws_.target[c] : row.normalVelocityChange(v));
      });
    });
  }
  const std::vector<int>* dofs() const override { return &ws_.dofs; }
  bool columns(SparseColumns& J, SparseColumns& K) const override {
    for (int c = 0; c < p_.size(); ++c)
      if (ws_.normal_var[c] >= 0)
        appendColumn(p_, c, Vector3(ws_.normal_scale[c], 0, 0), Vector2::Zero(), J, K);
    return true;
  }

 private:
  const ContactProblem& p_;
  const SolverWorkspace::Convex& ws_;
  const RowSchedule& schedule_;
  RowReader rows_;
};

// Stage 5b's rows: normal correction, tangential impulse and rolling impulse of each contact
// (see convex_stages.hpp).
class FrictionRows final : public QpOperator {
 public:
  FrictionRows(const ContactProblem& p, const FrictionStageOptions& options,
               const SolverWorkspace& nlgs, const RowSchedule& schedule)
      : p_(p),
        options_(options),
        nlgs_(nlgs),
        ws_(nlgs.convex),
        schedule_(schedule),
        dT_(p.dimension - 1),
        rows_(p, RowReader::kPacked2d | RowReader::kPacked3d | RowReader::kSpheres3d) {}

  void toVelocity(const std::vector<double>& x, VectorX& z) const override {
    clearVelocities(&ws_.dofs, z, schedule_.threads());
    schedule_.scatter([&](int c) {
      Vector3 dP = Vector3::Zero();
      if (ws_.normal_var[c] >= 0) dP.x() = x[ws_.normal_var[c]] * ws_.normal_scale[c];
      const int t = ws_.tangent_var[c];
      if (t >= 0) {
        const Vector2 impulse = ws_.tangent_map[c] * Vector2(x[t], dT_ == 2 ? x[t + 1] : 0.0);
        dP.y() = impulse.x();
        dP.z() = dT_ == 2 ? impulse.y() : 0.0;
        if (options_.tangents == TangentMode::Local) dP.x() -= nlgs_.coupling[c].dot(impulse);
      }
      Vector2 dR = Vector2::Zero();
      const int r = ws_.rolling_var[c];
      if (r >= 0) {
        const double scale = ws_.rolling_scale[c];
        dR = Vector2(x[r] * scale, dT_ == 2 ? x[r + 1] * scale : 0.0);
      }
      if (dP.isZero(0.0) && dR.isZero(0.0)) return;
      rows_.visit(c, [&](const auto& row) { row.apply(dP, dR, z); });
    });
  }

  void toGradient(const VectorX& v, bool affine, std::vector<double>& y) const override {
    schedule_.gather([&](int c) {
      const int n = ws_.normal_var[c], t = ws_.tangent_var[c], r = ws_.rolling_var[c];
      if (n < 0 && t < 0 && r < 0) return;
      Vector3 u;
      Vector2 u_rolling = Vector2::Zero();
      rows_.visit(c, [&](const auto& row) {
        if (affine)
          row.velocity(v, u, u_rolling);
        else
          row.velocityChange(v, u, u_rolling);
      });
      if (n >= 0) y[n] = ws_.normal_scale[c] * (affine ? u.x() - ws_.target[c] : u.x());
      if (t >= 0) {
        Vector2 w(u.y(), dT_ == 2 ? u.z() : 0.0);
        if (affine) w -= nlgs_.offset[c];
        if (options_.tangents == TangentMode::Local) w -= nlgs_.coupling[c] * u.x();
        const Vector2 gradient = ws_.tangent_map[c].transpose() * w;
        y[t] = gradient.x();
        if (dT_ == 2) y[t + 1] = gradient.y();
      }
      if (r >= 0) {
        y[r] = ws_.rolling_scale[c] * u_rolling.x();
        if (dT_ == 2) y[r + 1] = ws_.rolling_scale[c] * u_rolling.y();
      }
    });
  }
  const std::vector<int>* dofs() const override { return &ws_.dofs; }
  // in the variables' order: per row its normal correction, tangents, rolling rows
  bool columns(SparseColumns& J, SparseColumns& K) const override {
    for (int c = 0; c < p_.size(); ++c) {
      if (ws_.normal_var[c] >= 0)
        appendColumn(p_, c, Vector3(ws_.normal_scale[c], 0, 0), Vector2::Zero(), J, K);
      if (ws_.tangent_var[c] >= 0)
        for (int j = 0; j < dT_; ++j) {
          const Vector2 impulse = ws_.tangent_map[c].col(j);
          Vector3 dP(0.0, impulse.x(), dT_ == 2 ? impulse.y() : 0.0);
          if (options_.tangents == TangentMode::Local) dP.x() = -nlgs_.coupling[c].dot(impulse);
          appendColumn(p_, c, dP, Vector2::Zero(), J, K);
        }
      if (ws_.rolling_var[c] >= 0)
        for (int j = 0; j < dT_; ++j)
          appendColumn(p_, c, Vector3::Zero(), ws_.rolling_scale[c] * Vector2::Unit(j), J, K);
    }
    return true;
  }

 private:
  const ContactProblem& p_;
  const FrictionStageOptions& options_;
  const SolverWorkspace& nlgs_;
  const SolverWorkspace::Convex& ws_;
  const RowSchedule& schedule_;
  int dT_;
  RowReader rows_;
};

// The velocities the rows reach (M^-1 H's support holds H's: a row's components), in order.
void collectDofs(const ContactProblem& p, int nv, SolverWorkspace::Convex& ws) {
  if (static_cast<int>(ws.dof_stamp.size()) != nv) {
    ws.dof_stamp.assign(nv, 0);
    ws.stamp = 0;
  }
  if (++ws.stamp == 0) {  // wrapped: clear the marks once
    std::fill(ws.dof_stamp.begin(), ws.dof_stamp.end(), 0);
    ws.stamp = 1;
  }
  ws.dofs.clear();
  for (int c = 0; c < p.size(); ++c)
    p.forEachMovedDof(c, [&](int k) {
      if (ws.dof_stamp[k] == ws.stamp) return;
      ws.dof_stamp[k] = ws.stamp;
      ws.dofs.push_back(k);
    });
  std::sort(ws.dofs.begin(), ws.dofs.end());
}

// The stage's program by the stage's solver: the interior-point method when asked for, active-set
// Newton when asked for (auto: in 2D) and every set is a box, else MPRGP on boxes and APGD on
// discs.
MprgpStats solveProgram(const ContactProblem& p, const QpOperator& op,
                        const SolverSettings& settings, SolverWorkspace::Convex& ws,
                        ProjectedNewtonWorkspace& newton, VectorX& v) {
  if (settings.solver == StageSolver::InteriorPoint && interiorPointApplies(ws.set))
    return solveInteriorPoint(op, ws.set, mprgpSettings(settings), ws.x, v, newton,
                              ws.interior_point, ws.mprgp);
  const bool use_newton = settings.solver == StageSolver::Newton ||
                          (settings.solver == StageSolver::Auto && p.dimension == 2);
  if (use_newton && projectedNewtonApplies(ws.set))
    return solveProjectedNewton(op, ws.set, mprgpSettings(settings), ws.x, v, newton, ws.mprgp);
  return solveSeparableQp(op, ws.set, mprgpSettings(settings), ws.x, v, ws.mprgp);
}

void prepareRows(SolverWorkspace::Convex& ws, int n) {
  ws.set.clear();
  ws.normal_var.assign(n, -1);
  ws.tangent_var.assign(n, -1);
  ws.rolling_var.assign(n, -1);
  ws.normal_scale.assign(n, 0.0);
  ws.rolling_scale.assign(n, 0.0);
  ws.target.assign(n, 0.0);
  ws.tangent_map.resize(n);
}

}  // namespace

SolverStats solveNormalStageConvex(const ContactProblem& p, const SolverSettings& settings,
                                   std::vector<double>& lambda_N, VectorX& v,
                                   SolverWorkspace& nlgs) {
  SolverWorkspace::Convex& ws = nlgs.convex;
  const int n = p.size();
  if (n == 0) return SolverStats{};
  collectDofs(p, static_cast<int>(v.size()), ws);
  prepareRows(ws, n);
  ws.x.clear();
  for (int c = 0; c < n; ++c) {
    const double s = std::sqrt(p.delassus[c](0, 0));
    if (!(s > 0.0 && std::isfinite(s))) {  // a row that moves nothing carries nothing
      lambda_N[c] = 0.0;
      continue;
    }
    ws.normal_var[c] = ws.set.add(p.isBilateral(c) ? BlockSet::Free : BlockSet::NonNegative, 1);
    ws.normal_scale[c] = 1.0 / s;
    ws.target[c] = -p.normal_bias[c];
    ws.x.push_back(s * lambda_N[c]);
  }
  const RowSchedule schedule(p, settings, nlgs);
  const NormalRows op(p, ws, schedule);
  const MprgpStats solve = solveProgram(p, op, settings, ws, ws.newton_normal, v);
  for (int c = 0; c < n; ++c)
    if (ws.normal_var[c] >= 0) lambda_N[c] = ws.x[ws.normal_var[c]] * ws.normal_scale[c];
  SolverStats stats = statsOf(solve, n);
  if (!v.allFinite()) stats.status = SolverStatus::Failed;
  return stats;
}

long projectOnClosedNormalsByCg(const ContactProblem& p, const SolverSettings& settings,
                                const FrictionRowRule& rule, const VectorX& v,
                                SolverWorkspace& nlgs) {
  SolverWorkspace::Convex& ws = nlgs.convex;
  const int n = p.size();
  collectDofs(p, static_cast<int>(v.size()), ws);
  prepareRows(ws, n);
  ws.x.clear();
  for (int c = 0; c < n; ++c) {
    const double s_N = std::sqrt(p.delassus[c](0, 0));
    if (!rule.closed(c) || !(s_N > 0.0 && std::isfinite(s_N))) continue;
    // measured, as stage 5b measures a held row's drift, against the normal impulse the row
    // carries: the offsets need no more than the stage that reads them resolves
    const double carried = s_N * rule.lambda_N[c];
    ws.normal_var[c] = ws.set.add(BlockSet::Free, 1, 0.0, carried * carried);
    ws.normal_scale[c] = 1.0 / s_N;
    ws.target[c] = nlgs.held_normal[c];
    ws.x.push_back(0.0);
  }
  if (ws.v_normal.size() != v.size()) ws.v_normal.resize(v.size());
  ws.v_normal.setZero();
  const RowSchedule schedule(p, settings, nlgs);
  const NormalRows op(p, ws, schedule);
  const MprgpStats projection =
      solveProgram(p, op, settings, ws, ws.newton_projection, ws.v_normal);
  for (int c = 0; c < n; ++c) {
    const Vector3 u = p.localVelocity(c, ws.v_normal) - p.known[c];
    nlgs.offset[c] = Vector2(u.y(), u.z());
  }
  return static_cast<long>(projection.products) * n;
}

namespace {

// The program's blocks, each scaled to about a unit diagonal, and the warm start: per row its
// normal correction (held: free, guarded: >= 0), tangential impulse (a disc, an interval in
// 2D, the METRIC ellipse as a disc) and rolling impulse.
void addFrictionBlocks(const ContactProblem& p, const FrictionStageOptions& options,
                       const FrictionRowRule& rule, const std::vector<double>& delta,
                       const std::vector<Vector2>& lambda_T, const std::vector<Vector2>* R,
                       SolverWorkspace& nlgs) {
  SolverWorkspace::Convex& ws = nlgs.convex;
  const std::vector<double>& lambda_N = rule.lambda_N;
  const int n = p.size();
  const int dT = p.dimension - 1;
  auto rollingRow = [&](int c) {
    return R != nullptr && p.rolling && p.rolling_bound[c] > 0.0 && lambda_N[c] > 0.0;
  };
  prepareRows(ws, n);
  ws.x.clear();
  for (int c = 0; c < n; ++c) {
    const Matrix3& W = p.delassus[c];
    const double s_N = std::sqrt(W(0, 0));
    // rows that move nothing in a direction (a zero diagonal) carry nothing there
    auto usable = [](double scale) { return scale > 0.0 && std::isfinite(scale); };
    if ((rule.held(c) || rule.guarded(c)) && usable(s_N)) {
      // a held row's residual is measured against the normal impulse it carries (as NLGS)
      const double carried = s_N * lambda_N[c];
      ws.normal_var[c] = ws.set.add(rule.held(c) ? BlockSet::Free : BlockSet::NonNegative, 1, 0.0,
                                    carried * carried);
      ws.normal_scale[c] = 1.0 / s_N;
      ws.target[c] = rule.held(c) ? nlgs.held_normal[c] : -p.normal_bias[c];
      ws.x.push_back(rule.held(c) ? s_N * delta[c] : std::max(s_N * delta[c], 0.0));
    }
    const double S = nlgs.threshold[c];
    if (S > 0.0) {
      const Matrix2 diagonal =
          options.tangents == TangentMode::Local ? nlgs.schur[c] : Matrix2(W.block<2, 2>(1, 1));
      double radius = 0.0;
      bool valid = false;
      if (options.threshold == FrictionThreshold::Metric && p.dimension == 3) {
        // the ellipse lambda^T W_TT lambda <= S^2 W_NN is the disc |z| <= S sqrt(W_NN) in
        // z = L^T lambda, W_TT = L L^T
        const Eigen::LLT<Matrix2> L(W.block<2, 2>(1, 1));
        const Matrix2 Lt = L.matrixU();
        ws.tangent_map[c] = Lt.inverse();
        radius = S * s_N;
        valid = L.info() == Eigen::Success && ws.tangent_map[c].allFinite() && usable(s_N);
      } else {
        const double s_T = std::sqrt(p.dimension == 2 ? diagonal(0, 0) : 0.5 * diagonal.trace());
        ws.tangent_map[c] = Matrix2::Identity() / s_T;
        radius = S * s_T;
        valid = usable(s_T);
      }
      if (valid) {
        ws.tangent_var[c] = ws.set.add(BlockSet::Ball, dT, radius);
        const Vector2 warm = ws.tangent_map[c].inverse() * lambda_T[c];
        ws.x.push_back(warm.x());
        if (dT == 2) ws.x.push_back(warm.y());
      }
    }
    const double s_R = rollingRow(c)
                           ? std::sqrt(p.dimension == 2 ? p.rolling_delassus[c](0, 0)
                                                        : 0.5 * p.rolling_delassus[c].trace())
                           : 0.0;
    if (rollingRow(c) && usable(s_R)) {
      ws.rolling_scale[c] = 1.0 / s_R;
      ws.rolling_var[c] = ws.set.add(BlockSet::Ball, dT, p.rolling_bound[c] * lambda_N[c] * s_R);
      ws.x.push_back(s_R * (*R)[c].x());
      if (dT == 2) ws.x.push_back(s_R * (*R)[c].y());
    }
  }
}

}  // namespace

SolverStats solveFrictionStageConvex(const ContactProblem& p, const SolverSettings& settings,
                                     const FrictionStageOptions& options,
                                     const std::vector<double>& lambda_N,
                                     std::vector<double>& delta, std::vector<Vector2>& lambda_T,
                                     VectorX& v, SolverWorkspace& nlgs, std::vector<Vector2>* R,
                                     const std::vector<double>* threshold_impulse) {
  SolverWorkspace::Convex& ws = nlgs.convex;
  const int n = p.size();
  const int dT = p.dimension - 1;
  SolverStats total;
  if (n == 0) return total;
  collectDofs(p, static_cast<int>(v.size()), ws);
  prepareFrictionStage(p, options, lambda_N, threshold_impulse, v, nlgs);
  const FrictionRowRule rule{p, options, lambda_N};
  bool any = false;
  for (int c = 0; c < n; ++c)
    any = any || nlgs.threshold[c] > 0.0 ||
          (R != nullptr && p.rolling && p.rolling_bound[c] > 0.0 && lambda_N[c] > 0.0);
  if (!any) {
    // nothing can move the velocities: no friction, no correction
    std::fill(delta.begin(), delta.end(), 0.0);
    std::fill(lambda_T.begin(), lambda_T.end(), Vector2::Zero());
    if (R != nullptr) std::fill(R->begin(), R->end(), Vector2::Zero());
    return total;
  }

  std::fill(nlgs.offset.begin(), nlgs.offset.end(), Vector2::Zero());
  if (rule.needsProjection())
    total.updates += projectOnClosedNormalsByCg(p, settings, rule, v, nlgs);
  addFrictionBlocks(p, options, rule, delta, lambda_T, R, nlgs);
  const RowSchedule schedule(p, settings, nlgs);
  const FrictionRows op(p, options, nlgs, schedule);
  const MprgpStats solve = solveProgram(p, op, settings, ws, ws.newton_friction, v);
  for (int c = 0; c < n; ++c) {
    delta[c] = ws.normal_var[c] >= 0 ? ws.x[ws.normal_var[c]] * ws.normal_scale[c] : 0.0;
    const int t = ws.tangent_var[c];
    lambda_T[c] = t >= 0
                      ? Vector2(ws.tangent_map[c] * Vector2(ws.x[t], dT == 2 ? ws.x[t + 1] : 0.0))
                      : Vector2::Zero();
    if (R != nullptr) {
      const int r = ws.rolling_var[c];
      (*R)[c] = r >= 0
                    ? Vector2(ws.rolling_scale[c] * Vector2(ws.x[r], dT == 2 ? ws.x[r + 1] : 0.0))
                    : Vector2::Zero();
    }
  }
  SolverStats stats = statsOf(solve, n);
  stats.updates += total.updates;
  if (!v.allFinite()) stats.status = SolverStatus::Failed;
  return stats;
}

}  // namespace sweep
