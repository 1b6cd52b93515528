// A sparse Cholesky factorization on CHOLMOD, for the active-set Newton solver
// (integrators/projected_newton.hpp): the fill-reducing ordering (AMD; from 4096 rows one level
// of nested dissection), the symbolic and numeric factorization, kept between solves, and the
// triangular solves, split over threads as elimination_tree_split.cpp plans, with the same bits
// for every thread count.
#include "integrators/sparse_cholesky.hpp"

#include <omp.h>

#include <algorithm>
#include <atomic>

#include "integrators/cholmod_factor.hpp"

namespace sweep {
namespace detail {

CholmodFactor::CholmodFactor() {
  startCommon(common_);
  // the matrix given to cholmod_analyze is already in AMD order; no postorder, which would
  // permute it again
  common_.nmethods = 1;
  common_.method[0].ordering = CHOLMOD_NATURAL;
  common_.postorder = 0;
  // simplicial factors need no BLAS, whose threaded builds would make the bits depend on
  // the machine; the contact networks' factors are too sparse for supernodes to pay
  common_.supernodal = CHOLMOD_SIMPLICIAL;
  common_.final_ll = 0;
}

CholmodFactor::~CholmodFactor() {
  release();
  cholmod_finish(&common_);
  for (cholmod_common& c : thread_common_) cholmod_finish(&c);
}

void CholmodFactor::release() {
  if (factor_ != nullptr) cholmod_free_factor(&factor_, &common_);
  requested_threads_ = 0;
  scheduled_threads_ = 1;
}

bool CholmodFactor::analyze(int n, const std::vector<int>& begin, const std::vector<int>& row,
                            int threads) {
  if (factor_ != nullptr && n == n_ && begin == begin_ && row == row_) return schedule(threads);
  release();
  n_ = n;
  begin_ = begin;
  row_ = row;
  const int entries = static_cast<int>(row.size());
  cholmod_sparse lower = sparseView(n, begin_, row_, nullptr, -1);
  permutation_.resize(n);
  int separator = 0;
  if (n < kParallelRows) {
    if (!cholmod_amd(&lower, nullptr, 0, permutation_.data(), &common_)) return false;
  } else if (!dissection_.order(n, begin_, row_, threads, permutation_)) {
    return false;
  } else {
    separator = dissection_.separatorRows();
  }
  inverse_.resize(n);
  for (int k = 0; k < n; ++k) inverse_[permutation_[k]] = k;
  // the upper triangle of P A P^T by columns, rows sorted, and where each entry of A goes
  upper_begin_.assign(n + 1, 0);
  for (int j = 0; j < n; ++j)
    for (int e = begin[j]; e < begin[j + 1]; ++e)
      ++upper_begin_[std::max(inverse_[row[e]], inverse_[j]) + 1];
  for (int j = 0; j < n; ++j) upper_begin_[j + 1] += upper_begin_[j];
  slots_.resize(entries);
  fill_.assign(upper_begin_.begin(), upper_begin_.end() - 1);
  for (int j = 0; j < n; ++j)
    for (int e = begin[j]; e < begin[j + 1]; ++e) {
      const int a = inverse_[row[e]], b = inverse_[j];
      slots_[fill_[std::max(a, b)]++] = {std::min(a, b), e};
    }
  upper_row_.resize(entries);
  to_upper_.resize(entries);
  for (int j = 0; j < n; ++j) {
    std::sort(slots_.begin() + upper_begin_[j], slots_.begin() + upper_begin_[j + 1]);
    for (int k = upper_begin_[j]; k < upper_begin_[j + 1]; ++k) {
      upper_row_[k] = slots_[k].first;
      to_upper_[slots_[k].second] = k;
    }
  }
  upper_value_.assign(entries, 0.0);
  upper_ = sparseView(n, upper_begin_, upper_row_, upper_value_.data(), 1);
  factor_ = cholmod_analyze(&upper_, &common_);
  if (factor_ == nullptr || common_.status != CHOLMOD_OK || factor_->ordering != CHOLMOD_NATURAL)
    return false;
  parent_.resize(n);
  if (!cholmod_etree(&upper_, parent_.data(), &common_)) return false;
  analyzeTop(separator);
  if (top_first_ >= 0 && !cholmod_allocate_work(n, n, n, &common_)) return false;
  return schedule(threads);
}

bool CholmodFactor::factorize(const std::vector<double>& value) {
  for (std::size_t e = 0; e < value.size(); ++e) upper_value_[to_upper_[e]] = value[e];
  if (scheduled_threads_ <= 1 && top_first_ < 0) {
    const int ok = cholmod_factorize(&upper_, factor_, &common_);
    return ok && common_.status == CHOLMOD_OK && factor_->minor == factor_->n;
  }
  // as cholmod_factorize's simplicial branch: a symbolic factor becomes the identity, a
  // numeric one is emptied (rowfac resets it only for a whole factorization)
  if (factor_->xtype == CHOLMOD_PATTERN) {
    factor_->is_ll = 0;
    if (!cholmod_change_factor(CHOLMOD_REAL, 0, 0, 0, 1, factor_, &common_)) return false;
  } else {
    factor_->minor = factor_->n;
    int* column_count = static_cast<int*>(factor_->nz);
    std::fill(column_count, column_count + n_, 1);
  }
  double beta[2] = {0.0, 0.0};
  // row 0 (a leaf) first and alone: rowfac called from row 0 to row n would reset the whole
  // factor, under the other threads' feet
  if (!cholmod_rowfac(&upper_, nullptr, beta, 0, 1, factor_, &common_)) return false;
  bool ok = factor_->minor == factor_->n;
  // rowfac's rows end where the separator's Schur complement takes over
  const int rows_end = top_first_ >= 0 ? top_first_ : n_;
  if (scheduled_threads_ <= 1) {
    if (ok && !cholmod_rowfac(&upper_, nullptr, beta, 1, rows_end, factor_, &common_)) return false;
  } else {
    const int threads = scheduled_threads_;
    for (int h = 0; h < threads; ++h) progress_[h].done.store(0, std::memory_order_relaxed);
    std::atomic<bool> failed{false};
    int team = threads;
#pragma omp parallel num_threads(threads)
    {
#pragma omp single
      team = omp_get_num_threads();
      // the runs wait on each other: only a full team runs them (a nested region gets one
      // thread, which factorizes the rows in order below)
      if (team == threads) runTasks(omp_get_thread_num(), beta, failed);
    }
    if (team != threads) {
      if (!cholmod_rowfac(&upper_, nullptr, beta, 1, rows_end, factor_, &common_)) return false;
    } else if (failed.load()) {
      return false;
    }
  }
  if (!ok || common_.status != CHOLMOD_OK || factor_->minor != factor_->n) return false;
  return top_first_ < 0 || factorizeTop();
}

int CholmodFactor::threads() const {
  return scheduled_threads_;
}

void CholmodFactor::solve(const std::vector<double>& rhs, std::vector<double>& solution) {
  permuted_.resize(n_);
  for (int i = 0; i < n_; ++i) permuted_[inverse_[i]] = rhs[i];
  const int* begin = static_cast<const int*>(factor_->p);
  const int* count = static_cast<const int*>(factor_->nz);
  const int* row = static_cast<const int*>(factor_->i);
  const double* value = static_cast<const double*>(factor_->x);
  double* y = permuted_.data();
  // column j: its diagonal (D_jj) at begin_j, then its rows, increasing; forward subtracts
  // its entries from the first-th to the one before the last-th
  auto forward = [&](int j, int first, int last) {
    const double yj = y[j];
    for (int p = begin[j] + first; p < begin[j] + last; ++p) y[row[p]] -= value[p] * yj;
  };
  auto backward = [&](int j) {
    double xj = y[j] / value[begin[j]];
    for (int p = begin[j] + 1; p < begin[j] + count[j]; ++p) xj -= value[p] * y[row[p]];
    y[j] = xj;
  };
  const int threads = scheduled_threads_;
  if (threads <= 1) {
    for (int j = 0; j < n_; ++j) forward(j, 1, count[j]);
    for (int j = n_ - 1; j >= 0; --j) backward(j);
  } else {
#pragma omp parallel num_threads(threads)
    for (int chain = omp_get_thread_num(); chain < threads; chain += omp_get_num_threads())
      for (int r = solve_chain_begin_[chain]; r < solve_chain_begin_[chain + 1]; ++r) {
        const int j = solve_chain_row_[r];
        forward(j, 1, count[j] - top_count_[j]);
      }
    for (int j = 0; j < n_; ++j) forward(j, count[j] - top_count_[j], count[j]);
    for (int r = solve_chain_begin_[threads + 1] - 1; r >= solve_chain_begin_[threads]; --r)
      backward(solve_chain_row_[r]);
#pragma omp parallel num_threads(threads)
    for (int chain = omp_get_thread_num(); chain < threads; chain += omp_get_num_threads())
      for (int r = solve_chain_begin_[chain + 1] - 1; r >= solve_chain_begin_[chain]; --r)
        backward(solve_chain_row_[r]);
  }
  for (int i = 0; i < n_; ++i) solution[i] = y[inverse_[i]];
}

}  // namespace detail

struct SparseCholesky::Factor : detail::CholmodFactor {};

SparseCholesky::SparseCholesky() : factor_(std::make_unique<Factor>()) {}
SparseCholesky::~SparseCholesky() = default;
bool SparseCholesky::analyze(int n, const std::vector<int>& begin, const std::vector<int>& row,
                             int threads) {
  return factor_->analyze(n, begin, row, threads);
}
bool SparseCholesky::factorize(const std::vector<double>& value) {
  return factor_->factorize(value);
}
void SparseCholesky::solve(const std::vector<double>& rhs, std::vector<double>& solution) {
  factor_->solve(rhs, solution);
}
int SparseCholesky::threads() const {
  return factor_->threads();
}

}  // namespace sweep
