// The Delassus matrix the direct solvers form (projected_newton.hpp, interior_point.hpp): A from
// the operator's columns, its product with a vector, and the check of their answers through the
// operator.
#include "integrators/projected_newton.hpp"

#include <algorithm>

#include "framework/parallel.hpp"

namespace sweep {

// A = J^T K, lower triangle: Gustavson's product over J by velocity.
void formDelassus(ProjectedNewtonWorkspace& ws, const SeparableSet& set, int velocities) {
  const int n = set.variables;
  const SparseColumns &J = ws.J, &K = ws.K;
  ws.partner.assign(n, -1);
  for (int b = 0; b < set.blocks(); ++b)
    if (set.size[b] == 2) {
      ws.partner[set.first[b]] = set.first[b] + 1;
      ws.partner[set.first[b] + 1] = set.first[b];
    }
  // J by velocity (a counting sort of its entries)
  ws.by_dof_begin.assign(velocities + 1, 0);
  for (int r : J.row) ++ws.by_dof_begin[r + 1];
  for (int k = 0; k < velocities; ++k) ws.by_dof_begin[k + 1] += ws.by_dof_begin[k];
  ws.by_dof_variable.resize(J.row.size());
  ws.by_dof_value.resize(J.row.size());
  ws.touched.assign(ws.by_dof_begin.begin(), ws.by_dof_begin.end() - 1);  // fill positions
  for (int j = 0; j < n; ++j)
    for (int e = J.begin[j]; e < J.begin[j + 1]; ++e) {
      const int slot = ws.touched[J.row[e]]++;
      ws.by_dof_variable[slot] = j;
      ws.by_dof_value[slot] = J.value[e];
    }
  // column j of A: sum over K's entries (k, K_kj) of J's row k times K_kj, rows i >= j
  ws.accumulator.assign(n, 0.0);
  ws.marker.assign(n, -1);
  ws.touched.clear();
  ws.a_begin.assign(1, 0);
  ws.a_row.clear();
  ws.a_value.clear();
  for (int j = 0; j < n; ++j) {
    ws.touched.clear();
    const auto touch = [&](int i) {
      if (i >= j && ws.marker[i] != j) {
        ws.marker[i] = j;
        ws.touched.push_back(i);
      }
    };
    touch(j);  // the diagonal always, so that every column has a pivot
    for (int e = K.begin[j]; e < K.begin[j + 1]; ++e) {
      const int k = K.row[e];
      const double kv = K.value[e];
      for (int s = ws.by_dof_begin[k]; s < ws.by_dof_begin[k + 1]; ++s) {
        const int i = ws.by_dof_variable[s];
        if (i < j) continue;
        touch(i);
        ws.accumulator[i] += ws.by_dof_value[s] * kv;
      }
    }
    // the disc's other column's rows, and the partners of all rows: whole 2 x 2 couplings
    if (ws.partner[j] >= 0) {
      const int pj = ws.partner[j];
      for (int e = K.begin[pj]; e < K.begin[pj + 1]; ++e)
        for (int s = ws.by_dof_begin[K.row[e]]; s < ws.by_dof_begin[K.row[e] + 1]; ++s)
          touch(ws.by_dof_variable[s]);
    }
    for (std::size_t t = 0, rows = ws.touched.size(); t < rows; ++t)
      if (ws.partner[ws.touched[t]] >= 0) touch(ws.partner[ws.touched[t]]);
    std::sort(ws.touched.begin(), ws.touched.end());
    for (int i : ws.touched) {
      ws.a_row.push_back(i);
      ws.a_value.push_back(ws.accumulator[i]);
      ws.accumulator[i] = 0.0;
    }
    ws.a_begin.push_back(static_cast<int>(ws.a_row.size()));
  }
  // A by rows: row i holds the lower triangle's row i (columns j < i), then its column i (the
  // diagonal and below, by symmetry); walking the columns in order appends each row's entries
  // in increasing column order
  ws.full_begin.assign(n + 1, 0);
  for (int j = 0; j < n; ++j)
    for (int e = ws.a_begin[j]; e < ws.a_begin[j + 1]; ++e) {
      ++ws.full_begin[ws.a_row[e] + 1];
      if (ws.a_row[e] != j) ++ws.full_begin[j + 1];
    }
  for (int i = 0; i < n; ++i) ws.full_begin[i + 1] += ws.full_begin[i];
  const int entries = ws.full_begin[n];
  ws.full_column.resize(entries);
  ws.full_value.resize(entries);
  ws.touched.assign(ws.full_begin.begin(), ws.full_begin.end() - 1);  // fill positions
  for (int j = 0; j < n; ++j)
    for (int e = ws.a_begin[j]; e < ws.a_begin[j + 1]; ++e) {
      const int i = ws.a_row[e];
      int slot = ws.touched[i]++;
      ws.full_column[slot] = j;
      ws.full_value[slot] = ws.a_value[e];
      if (i == j) continue;
      slot = ws.touched[j]++;
      ws.full_column[slot] = i;
      ws.full_value[slot] = ws.a_value[e];
    }
}

// y = A x + b, row by row on threads: each y_i summed over its row in increasing column order,
// the order of a product over the lower triangle by columns, whatever the thread count
void delassusGradient(const ProjectedNewtonWorkspace& ws, const std::vector<double>& x,
                      std::vector<double>& y, int threads) {
  forEachIndex(static_cast<long>(x.size()), threads, [&](long i) {
    double sum = ws.b[i];
    for (int e = ws.full_begin[i]; e < ws.full_begin[i + 1]; ++e)
      sum += ws.full_value[e] * x[ws.full_column[e]];
    y[i] = sum;
  });
}

bool acceptDirectAnswer(const QpOperator& op, const SeparableSet& set,
                        const MprgpSettings& settings, const std::vector<double>& x, bool candidate,
                        VectorX& v, std::vector<double>& g, MprgpWorkspace& fallback,
                        MprgpStats& stats) {
  const int n = set.variables;
  // in z_trial, so that a fallback starts from v as given
  fallback.prepare(n, static_cast<int>(v.size()));
  op.toVelocity(x, fallback.z);
  VectorX &z = fallback.z, &v_x = fallback.z_trial;
  const std::vector<int>* dofs = op.dofs();
  if (dofs != nullptr)
    for (int k : *dofs) v_x[k] = v[k] + z[k];
  else
    v_x = v + z;
  op.toGradient(v_x, true, g);
  stats.products += 2;
  stats.residual = naturalResidual(set, x, g);
  stats.converged = candidate && stats.residual <= settings.tolerance;
  if (!stats.converged) return false;
  if (dofs != nullptr)
    for (int k : *dofs) v[k] = v_x[k];
  else
    v = v_x;
  return true;
}

}  // namespace sweep
