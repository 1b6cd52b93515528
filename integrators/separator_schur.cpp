// A dissected matrix's separator rows factorized by their Schur complement, dense and on
// threads (CholmodFactor::analyzeTop, cholmod_factor.hpp says how), with the same bits for
// every thread count.
#include <algorithm>
#include <cmath>

#include "framework/parallel.hpp"
#include "integrators/cholmod_factor.hpp"

namespace sweep {
namespace detail {

void CholmodFactor::analyzeTop(int separator) {
  top_first_ = -1;
  if (separator < 1 || separator > kMaxSchurRows) return;
  const int n = n_, m = n - separator, s = separator;
  // row k's pattern: its columns below k, by the row subtree of the elimination tree
  std::vector<int>& mark = fill_;  // free after the analysis
  mark.assign(n, -1);
  top_begin_.assign(1, 0);
  top_column_.clear();
  separator_begin_.assign(s + 1, 0);                   // counts first, by column
  std::vector<int>& pattern = child_;                  // free until the split's children lists
  std::vector<std::pair<int, int>> separator_entries;  // (row, column) of L22, by rows
  for (int k = m; k < n; ++k) {
    mark[k] = k;
    pattern.clear();
    for (int e = upper_begin_[k]; e < upper_begin_[k + 1]; ++e)
      for (int i = upper_row_[e]; i >= 0 && i < k && mark[i] != k; i = parent_[i]) {
        mark[i] = k;
        pattern.push_back(i);
      }
    std::sort(pattern.begin(), pattern.end());
    for (int i : pattern) {
      if (i < m) {
        top_column_.push_back(i);
      } else {
        ++separator_begin_[i - m + 1];
        separator_entries.push_back({k - m, i - m});
      }
    }
    top_begin_.push_back(static_cast<int>(top_column_.size()));
  }
  // the sides' columns' entries in the separator's rows, increasing rows
  column_begin_.assign(m + 1, 0);
  for (int i : top_column_) ++column_begin_[i + 1];
  for (int i = 0; i < m; ++i) column_begin_[i + 1] += column_begin_[i];
  column_row_.resize(top_column_.size());
  column_position_.resize(top_column_.size());
  {
    std::vector<int>& next = mark;
    next.assign(column_begin_.begin(), column_begin_.end() - 1);
    for (int a = 0; a < s; ++a)
      for (int p = top_begin_[a]; p < top_begin_[a + 1]; ++p) {
        const int q = next[top_column_[p]]++;
        column_row_[q] = a;
        column_position_[q] = p;
      }
  }
  // the separator's columns' entries (rows below the diagonal, increasing)
  for (int b = 0; b < s; ++b) separator_begin_[b + 1] += separator_begin_[b];
  separator_row_.resize(separator_begin_[s]);
  {
    std::vector<int> next(separator_begin_.begin(), separator_begin_.end() - 1);
    for (const auto& [a, b] : separator_entries) separator_row_[next[b]++] = a;
  }
  top_l_.assign(top_column_.size(), 0.0);
  top_u_.assign(top_column_.size(), 0.0);
  schur_.assign(static_cast<std::size_t>(s) * s, 0.0);
  schur_u_.assign(static_cast<std::size_t>(s) * s, 0.0);
  pivot_.assign(s, 0.0);
  top_first_ = m;
}

bool CholmodFactor::factorizeTop() {
  const int m = top_first_, s = n_ - m;
  const int threads = std::max(1, requested_threads_);
  const int* lp = static_cast<const int*>(factor_->p);
  int* lnz = static_cast<int*>(factor_->nz);
  int* li = static_cast<int*>(factor_->i);
  double* lx = static_cast<double*>(factor_->x);
  // L21's rows: y = L11^-1 A(0:m, k) through the sides' columns as they stand (their
  // entries in the sides' rows), in increasing column order; L(k, i) = y_i / D_i
  parallelFor(threads, threads, [&](int t) {
    double* w = scatter_[t].data();
    for (int a = t; a < s; a += threads) {
      const int k = m + a;
      for (int e = upper_begin_[k]; e < upper_begin_[k + 1]; ++e)
        if (upper_row_[e] < m) w[upper_row_[e]] = upper_value_[e];
      for (int p = top_begin_[a]; p < top_begin_[a + 1]; ++p) {
        const int i = top_column_[p];
        const double yi = w[i];
        w[i] = 0.0;
        for (int q = lp[i] + 1; q < lp[i] + lnz[i]; ++q) w[li[q]] -= lx[q] * yi;
        top_u_[p] = yi;
        top_l_[p] = yi / lx[lp[i]];
      }
    }
  });
  // S = A22 - L21 D1 L21^T, row a on thread a mod threads, each entry's terms in increasing
  // column order
  std::fill(schur_.begin(), schur_.end(), 0.0);
  parallelFor(threads, threads, [&](int t) {
    for (int a = t; a < s; a += threads) {
      const int k = m + a;
      for (int e = upper_begin_[k]; e < upper_begin_[k + 1]; ++e)
        if (upper_row_[e] >= m)
          schur_[static_cast<std::size_t>(a) * s + upper_row_[e] - m] = upper_value_[e];
    }
    for (int i = 0; i < m; ++i)
      for (int q = column_begin_[i]; q < column_begin_[i + 1]; ++q) {
        const int a = column_row_[q];
        if (a % threads != t) continue;
        const double la = top_l_[column_position_[q]];
        double* row = schur_.data() + static_cast<std::size_t>(a) * s;
        for (int r = column_begin_[i]; r <= q; ++r)
          row[column_row_[r]] -= la * top_u_[column_position_[r]];
      }
  });
  // L22 D2 L22^T = S, up-looking: row a's L in schur_, its L D in schur_u_
  for (int a = 0; a < s; ++a) {
    double* la = schur_.data() + static_cast<std::size_t>(a) * s;
    double* ua = schur_u_.data() + static_cast<std::size_t>(a) * s;
    for (int b = 0; b < a; ++b) {
      const double* ub = schur_u_.data() + static_cast<std::size_t>(b) * s;
      double sum = la[b];
      for (int c = 0; c < b; ++c) sum -= la[c] * ub[c];
      ua[b] = sum;
      la[b] = sum / pivot_[b];
    }
    double d = la[a];
    for (int c = 0; c < a; ++c) d -= la[c] * ua[c];
    // as CHOLMOD's LDL^T: a zero (or not finite) pivot stops it
    if (!(d != 0.0) || !std::isfinite(d)) {
      factor_->minor = static_cast<size_t>(m + a);
      return false;
    }
    pivot_[a] = d;
  }
  // into CHOLMOD's columns: each side column's entries in the separator's rows after its
  // own, each separator column whole
  bool fits = true;
  forEachIndex(m, threads, [&](int i) {
    const int count = column_begin_[i + 1] - column_begin_[i];
    if (count == 0) return;
    const int first = lp[i] + lnz[i];
    if (first + count > lp[i + 1]) {
      fits = false;
      return;
    }
    for (int q = column_begin_[i]; q < column_begin_[i + 1]; ++q) {
      li[first + q - column_begin_[i]] = m + column_row_[q];
      lx[first + q - column_begin_[i]] = top_l_[column_position_[q]];
    }
    lnz[i] += count;
  });
  for (int b = 0; b < s; ++b) {
    const int j = m + b;
    lx[lp[j]] = pivot_[b];
    int p = lp[j] + 1;
    for (int q = separator_begin_[b]; q < separator_begin_[b + 1]; ++q, ++p) {
      const int a = separator_row_[q];
      li[p] = m + a;
      lx[p] = schur_[static_cast<std::size_t>(a) * s + b];
    }
    lnz[j] = p - lp[j];
  }
  return fits;
}

}  // namespace detail
}  // namespace sweep
