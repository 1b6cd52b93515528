// A sparse Cholesky factorization on CHOLMOD, for the active-set Newton solver
// (integrators/projected_newton.hpp): the fill-reducing ordering (AMD; from 4096 rows one level
// of nested dissection), the symbolic and numeric factorization, kept between solves, split
// along the elimination tree on threads, and the triangular solves, with the same bits for
// every thread count.
#include "integrators/sparse_cholesky.hpp"

#include <cholmod.h>
#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <deque>
#include <limits>
#include <thread>
#include <utility>

#include "framework/parallel.hpp"
#include "integrators/nested_dissection.hpp"

namespace sweep {

namespace {

// CHOLMOD's common block, the fill-reducing permutation, the matrix permuted into CHOLMOD's
// own working form and the symbolic and numeric factor, all kept between solves. The matrix
// is permuted here, once per pattern, so that each numeric factorization reads it in place:
// CHOLMOD's simplicial factorization of a matrix with a permutation would build a transposed,
// permuted copy every time (an allocation inside the solver's iterations and, measured, 7 % of
// the 500-disk funnel's run). A pattern equal to the last one's reuses all of it.
//
// On threads, the factorization is CHOLMOD's own up-looking one (cholmod_rowfac), split along
// the elimination tree: row k of L reads only the rows of k's subtree, so rows in disjoint
// subtrees are factorized at once, each thread with its own CHOLMOD workspace. The tree is cut
// into tasks (small subtrees whole, single rows above them), list-scheduled onto the threads,
// each thread waiting only for the tasks of other threads that its next one reads
// (assignTasks). The separator of a dissected matrix comes last, by its Schur complement
// (factorizeTop). Each row is computed by the same arithmetic whichever thread computes it and
// whatever the split: the factor has the same bits for every thread count.
class CholmodFactor {
 public:
  CholmodFactor() {
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
  ~CholmodFactor() {
    release();
    cholmod_finish(&common_);
    for (cholmod_common& c : thread_common_) cholmod_finish(&c);
  }
  CholmodFactor(const CholmodFactor&) = delete;
  CholmodFactor& operator=(const CholmodFactor&) = delete;

  void release() {
    if (factor_ != nullptr) cholmod_free_factor(&factor_, &common_);
    requested_threads_ = 0;
    scheduled_threads_ = 1;
  }

  // The ordering (AMD, on A + A^T) and the symbolic factorization of the n x n matrix whose
  // lower triangle has the compressed columns (begin, row), rows sorted; kept when the
  // pattern is the last one's. The split for `threads` threads is made here too.
  bool analyze(int n, const std::vector<int>& begin, const std::vector<int>& row, int threads) {
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
  // the numeric factorization of the matrix with these values (in the order of `row`)
  bool factorize(const std::vector<double>& value) {
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
      if (ok && !cholmod_rowfac(&upper_, nullptr, beta, 1, rows_end, factor_, &common_))
        return false;
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
  int threads() const {
    return scheduled_threads_;
  }
  // solution = A^-1 rhs: L y = P rhs, then L^T (P solution) = D^-1 y, on the factor's columns.
  // Split as the factorization is: a subtree row's y takes terms only from its own subtree's
  // columns, so the subtrees' columns run at once, each on its chain's thread, leaving out their
  // entries in the top's rows; then one pass over every column's entries in the top's rows, in
  // column order, completes those. Every y_i subtracts its terms in increasing column order and
  // every x_j its terms in increasing row order, as a plain column-by-column solve does: the
  // same bits for every split.
  void solve(const std::vector<double>& rhs, std::vector<double>& solution) {
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

 private:
  // The separator's rows (the last s = n - m of the dissection's order) by their Schur
  // complement. Row by row they are a chain of the elimination tree that no two threads can
  // share, each row reaching back into hundreds of the sides' columns (the 80 000-disk pile's
  // stage 5b: 200 rows, 16 % of the flops). With L11 D1 L11^T the sides' factor (rowfac):
  //   L21 D1 = A21 L11^-T          row by row, each a sparse triangular solve on its own
  //   S = A22 - L21 D1 L21^T       entry by entry, the sides' columns in increasing order
  //   L22 D2 L22^T = S             dense, up-looking
  // The rows of L21 and of S are dealt to the threads; each entry's arithmetic does not depend
  // on who computes it: the same bits for every thread count. Taken for separators of 1 to
  // kMaxSchurRows rows (top_first_ = m); larger ones go row by row with the rest
  // (top_first_ = -1).
  void analyzeTop(int separator) {
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

  bool factorizeTop() {
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

  // separators above this many rows are factorized row by row: their dense blocks (two of
  // s x s) would outgrow what the sparse rows save
  static constexpr int kMaxSchurRows = 2048;
  // matrices with fewer rows are ordered by AMD alone and factorized on one thread: the split
  // would cost more than it gains
  static constexpr int kParallelRows = 4096;
  // a task holds a subtree of at most this fraction of a thread's share of the work
  static constexpr double kGrainsPerThread = 8.0;
  // a split is used when its estimated time is below this fraction of one thread's
  static constexpr double kWorthwhile = 0.9;

  // The split over `threads` threads (the tasks, their threads and each thread's runs), when
  // its estimated time is a tenth below one thread's; else rows on one thread
  // (scheduled_threads_ = 1).
  bool schedule(int threads) {
    threads = std::max(1, threads);
    if (threads == requested_threads_) return true;
    requested_threads_ = threads;
    scheduled_threads_ = 1;
    if (top_first_ >= 0) {
      scatter_.resize(threads);
      for (std::vector<double>& w : scatter_) w.assign(top_first_, 0.0);
    }
    if (threads == 1 || n_ < kParallelRows) return true;
    const int n = n_;
    measureSubtrees();
    const double all = subtree_work_total_;
    const double best_time = assignTasks(threads);
    // a split worth its threads: a tenth off the time at least
    if (best_time > kWorthwhile * all) return true;
    buildRuns(threads);
    // each thread's own workspace, sized here, outside the factorizations
    while (static_cast<int>(thread_common_.size()) < threads) {
      thread_common_.emplace_back();
      startCommon(thread_common_.back());
    }
    for (int t = 0; t < threads; ++t)
      if (!cholmod_allocate_work(n, n, n, &thread_common_[t])) return false;
    if (!cholmod_allocate_work(n, n, n, &common_)) return false;
    progress_ = std::make_unique<Progress[]>(threads);
    scheduled_threads_ = threads;
    return true;
  }

  // subtree_work_ and the children lists (child_begin_, child_) of the elimination tree
  void measureSubtrees() {
    const int n = n_;
    // Each row's work in the up-looking factorization: for each entry L(k, i) of its row, the
    // entries column i holds so far. The rows' patterns come from the elimination tree (the
    // row subtrees, as rowfac finds them): O(entries of L), a fraction of one factorization.
    subtree_work_.assign(n, 0.0);
    {
      std::vector<int>& held = fill_;  // entries of each column so far (fill_ is free now)
      std::vector<int>& mark = child_;
      held.assign(n, 0);
      mark.assign(n, -1);
      for (int k = 0; k < n; ++k) {
        mark[k] = k;
        double work = 1.0;
        for (int e = upper_begin_[k]; e < upper_begin_[k + 1]; ++e)
          for (int i = upper_row_[e]; i >= 0 && i < k && mark[i] != k; i = parent_[i]) {
            mark[i] = k;
            work += ++held[i];
          }
        subtree_work_[k] = work;
      }
    }
    row_work_ = subtree_work_;
    // subtree work, children lists (parent_[j] > j: one pass upwards)
    child_begin_.assign(n + 2, 0);
    for (int j = 0; j < n; ++j) {
      if (parent_[j] >= 0) {
        subtree_work_[parent_[j]] += subtree_work_[j];
        ++child_begin_[parent_[j] + 1];
      } else {
        ++child_begin_[n + 1];  // roots, listed as the children of a virtual node n
      }
    }
    for (int j = 0; j <= n; ++j) child_begin_[j + 1] += child_begin_[j];
    child_.resize(n);
    {
      std::vector<int>& next = fill_;  // reused: the analysis is done with it
      next.assign(child_begin_.begin(), child_begin_.end() - 1);
      for (int j = 0; j < n; ++j) child_[next[parent_[j] >= 0 ? parent_[j] : n]++] = j;
    }
    subtree_work_total_ = 0.0;
    for (int e = child_begin_[n]; e < child_begin_[n + 1]; ++e)
      subtree_work_total_ += subtree_work_[child_[e]];
  }

  // thread h's runs: each after the other threads' tasks it reads, then its rows by rowfac,
  // on a copy of the factor's header (rowfac records a zero pivot in its `minor`, which the
  // threads would otherwise share; the arrays are shared, each row writes only its subtree's
  // columns, and no column grows past the count the analysis gave it, so rowfac never
  // reallocates them under the other threads)
  void runTasks(int h, double* beta, std::atomic<bool>& failed) {
    cholmod_factor own = *factor_;
    for (int r = run_begin_[h]; r < run_begin_[h + 1]; ++r) {
      const Run& run = run_[r];
      for (int w = run.wait_begin; w < run.wait_end; ++w) {
        const auto [thread, done] = run_wait_[w];
        for (int spin = 0; progress_[thread].done.load(std::memory_order_acquire) < done; ++spin) {
          if (failed.load(std::memory_order_relaxed)) return;
          if (spin > 64) std::this_thread::yield();
        }
      }
      if (run.first >= 0 && (!cholmod_rowfac_mask(&upper_, nullptr, beta, run.first, n_, nullptr,
                                                  link_.data(), &own, &thread_common_[h]) ||
                             own.minor != own.n)) {
        failed.store(true);
        return;
      }
      progress_[h].done.store(run.done, std::memory_order_release);
    }
  }

  // The tasks and their threads. A task is a subtree whose work is at most a grain (a share
  // of a thread's work), its rows at once, or a single row above those. Row k of L reads only
  // the rows of k's subtree, so a task may start once its children's tasks are done. The
  // tasks are list-scheduled (Topcuoglu, Hariri & Wu 2002, "Performance-effective and
  // low-complexity task scheduling for heterogeneous computing", IEEE TPDS 13: HEFT, here
  // without communication costs): taken by decreasing bottom level (the work from the task
  // to the tree's root, so children come before their parents), each given to the thread
  // where it would finish first. The side trees' own top rows, which a split into disjoint
  // subtrees leaves to one thread after all the others, then run beside the other side's
  // subtrees. Rows from the separator on (top_first_) are left to factorizeTop. Returns the
  // estimated time.
  double assignTasks(int threads) {
    const int n = n_;
    const int rows_end = top_first_ >= 0 ? top_first_ : n;
    grain_ = subtree_work_total_ / (threads * kGrainsPerThread);
    const double grain = grain_;
    // task_of_[j]: the task row j belongs to (its root's index in task_root_)
    task_root_.clear();
    task_of_.assign(n, -1);
    for (int j = rows_end - 1; j >= 0; --j) {
      const int p = parent_[j];
      const bool parent_in = p >= 0 && p < rows_end;
      if (parent_in && subtree_work_[p] <= grain) {
        task_of_[j] = task_of_[p];  // inside its parent's subtree task
      } else {
        task_of_[j] = static_cast<int>(task_root_.size());
        task_root_.push_back(j);
      }
    }
    const int tasks = static_cast<int>(task_root_.size());
    // a task's work (a whole subtree, or the row alone), its parent task, its bottom level
    task_work_.resize(tasks);
    task_parent_.resize(tasks);
    task_level_.resize(tasks);
    for (int t = 0; t < tasks; ++t) {  // roots in decreasing row order: parents first
      const int r = task_root_[t];
      const bool whole = subtree_work_[r] <= grain;
      task_work_[t] = whole ? subtree_work_[r] : row_work_[r];
      const int p = parent_[r];
      task_parent_[t] = p >= 0 && p < rows_end ? task_of_[p] : -1;
      task_level_[t] = task_work_[t] + (task_parent_[t] >= 0 ? task_level_[task_parent_[t]] : 0.0);
    }
    task_order_.resize(tasks);
    for (int t = 0; t < tasks; ++t) task_order_[t] = t;
    std::stable_sort(task_order_.begin(), task_order_.end(),
                     [&](int a, int b) { return task_level_[a] > task_level_[b]; });
    // each task on the thread where it finishes first, after its children
    task_ready_.assign(tasks, 0.0);  // the latest finish of its children so far
    task_thread_.assign(tasks, 0);
    task_finish_.assign(tasks, 0.0);
    load_.assign(threads, 0.0);
    double finish_all = 0.0;
    for (int t : task_order_) {
      int best = 0;
      double best_finish = 0.0;
      for (int h = 0; h < threads; ++h) {
        const double finish = std::max(load_[h], task_ready_[t]) + task_work_[t];
        if (h == 0 || finish < best_finish) {
          best = h;
          best_finish = finish;
        }
      }
      task_thread_[t] = best;
      task_finish_[t] = best_finish;
      load_[best] = best_finish;
      if (task_parent_[t] >= 0)
        task_ready_[task_parent_[t]] = std::max(task_ready_[task_parent_[t]], best_finish);
      finish_all = std::max(finish_all, best_finish);
    }
    // what factorizeTop does after, or rowfac's rows above, costed as rows on one thread
    for (int j = rows_end; j < n; ++j) finish_all += row_work_[j];
    return finish_all;
  }

  // Each thread's runs (its tasks in the order they were given to it; a run ends before a task
  // that waits on another thread's), the rows' links within each run, and the solve's split:
  // the rows of whole-subtree tasks by their thread, the others (the top's) after them
  void buildRuns(int threads) {
    const int n = n_;
    const int rows_end = top_first_ >= 0 ? top_first_ : n;
    const int tasks = static_cast<int>(task_root_.size());
    task_position_.assign(tasks, 0);
    thread_tasks_.assign(threads, {});
    for (int t : task_order_) {
      task_position_[t] = static_cast<int>(thread_tasks_[task_thread_[t]].size());
      thread_tasks_[task_thread_[t]].push_back(t);
    }
    // each task's rows, increasing (row 0, factorized alone first, left out)
    task_row_begin_.assign(tasks + 1, 0);
    for (int j = 1; j < rows_end; ++j) ++task_row_begin_[task_of_[j] + 1];
    for (int t = 0; t < tasks; ++t) task_row_begin_[t + 1] += task_row_begin_[t];
    task_row_.resize(task_row_begin_[tasks]);
    {
      std::vector<int>& next = fill_;
      next.assign(task_row_begin_.begin(), task_row_begin_.end() - 1);
      for (int j = 1; j < rows_end; ++j) task_row_[next[task_of_[j]]++] = j;
    }
    // a task another thread waits on ends its run, which then publishes the thread's count
    std::vector<char> awaited(tasks, 0);
    for (int t = 0; t < tasks; ++t)
      if (task_parent_[t] >= 0 && task_thread_[task_parent_[t]] != task_thread_[t]) awaited[t] = 1;
    std::vector<int> wait_on(threads);
    run_.clear();
    run_wait_.clear();
    link_.assign(n, n);
    run_begin_.assign(threads + 1, 0);
    for (int h = 0; h < threads; ++h) {
      run_begin_[h] = static_cast<int>(run_.size());
      int last_row = -1;
      bool run_ended = true;
      for (std::size_t q = 0; q < thread_tasks_[h].size(); ++q) {
        const int t = thread_tasks_[h][q];
        // the tasks of the root's children on other threads: wait until each thread has done
        // its list up to them
        std::fill(wait_on.begin(), wait_on.end(), 0);
        bool waits = false;
        const int r = task_root_[t];
        for (int e = child_begin_[r]; e < child_begin_[r + 1]; ++e) {
          const int c = task_of_[child_[e]];
          if (c == t || task_thread_[c] == h) continue;
          wait_on[task_thread_[c]] = std::max(wait_on[task_thread_[c]], task_position_[c] + 1);
          waits = true;
        }
        if (run_ended || waits) {
          Run run;
          run.wait_begin = static_cast<int>(run_wait_.size());
          for (int o = 0; o < threads; ++o)
            if (wait_on[o] > 0) run_wait_.push_back({o, wait_on[o]});
          run.wait_end = static_cast<int>(run_wait_.size());
          run_.push_back(run);
          last_row = -1;
        }
        Run& run = run_.back();
        run.done = static_cast<int>(q) + 1;
        for (int p = task_row_begin_[t]; p < task_row_begin_[t + 1]; ++p) {
          const int j = task_row_[p];
          if (last_row < 0)
            run.first = j;
          else
            link_[last_row] = j;
          last_row = j;
        }
        run_ended = awaited[t] != 0;
      }
    }
    run_begin_[threads] = static_cast<int>(run_.size());
    owner_.assign(n, -1);
    for (int j = 0; j < rows_end; ++j)
      if (subtree_work_[task_root_[task_of_[j]]] <= grain_) owner_[j] = task_thread_[task_of_[j]];
    auto chainOf = [&](int j) { return owner_[j] >= 0 ? owner_[j] : threads; };
    solve_chain_begin_.assign(threads + 3, 0);
    for (int j = 0; j < n; ++j) ++solve_chain_begin_[chainOf(j) + 2];
    for (int c = 0; c <= threads; ++c) solve_chain_begin_[c + 2] += solve_chain_begin_[c + 1];
    solve_chain_row_.resize(n);
    for (int j = 0; j < n; ++j) solve_chain_row_[solve_chain_begin_[chainOf(j) + 1]++] = j;
    // each column's entries in the top's rows: the last ones of the column (a column's rows
    // are its ancestors, and the top's rows come above its subtree's)
    top_count_.assign(n, 0);
    std::vector<int>& mark = fill_;  // free again
    mark.assign(n, -1);
    for (int k = 0; k < n; ++k) {
      if (owner_[k] >= 0) continue;
      mark[k] = k;
      for (int e = upper_begin_[k]; e < upper_begin_[k + 1]; ++e)
        for (int i = upper_row_[e]; i >= 0 && i < k && mark[i] != k; i = parent_[i]) {
          mark[i] = k;
          ++top_count_[i];
        }
    }
  }

  cholmod_common common_{};
  int n_ = -1;
  std::vector<int> begin_, row_;  // the analysed pattern (lower triangle of A)
  std::vector<int> permutation_, inverse_;
  std::vector<int> upper_begin_, upper_row_, to_upper_, fill_;
  std::vector<std::pair<int, int>> slots_;
  std::vector<double> upper_value_, permuted_;
  cholmod_sparse upper_{};
  cholmod_factor* factor_ = nullptr;
  DissectionOrdering dissection_;
  // the split over threads (schedule)
  int requested_threads_ = 0;  // the thread count the split was made for (0: none yet)
  int scheduled_threads_ = 1;  // the threads it uses
  std::vector<int> parent_, child_begin_, child_, owner_, link_;
  std::vector<double> subtree_work_, row_work_, load_;
  double subtree_work_total_ = 0.0;  // the roots' subtree work: all the work
  // the tasks (assignTasks): each one's root row, work, parent task, bottom level, thread,
  // place in its thread's list, finish; each row's task; the tasks by decreasing level
  double grain_ = 0.0;
  std::vector<int> task_root_, task_of_, task_parent_, task_thread_, task_position_, task_order_;
  std::vector<double> task_work_, task_level_, task_ready_, task_finish_;
  std::vector<int> task_row_begin_, task_row_;
  std::vector<std::vector<int>> thread_tasks_;
  // each thread's runs (run_begin_[h] ..): the rows from `first` along link_, after waiting
  // until each listed thread has done that many of its tasks; `done`: this thread's count after
  struct Run {
    int wait_begin = 0, wait_end = 0, first = -1, done = 0;
  };
  std::vector<Run> run_;
  std::vector<std::pair<int, int>> run_wait_;  // (thread, tasks done)
  std::vector<int> run_begin_;
  struct alignas(64) Progress {
    std::atomic<int> done{0};
  };
  std::unique_ptr<Progress[]> progress_;  // each thread's tasks done in this factorization
  // the solve's split: chain c's rows from solve_chain_begin_[c] (the top's: c = threads), and
  // each column's entries in the top's rows
  std::vector<int> solve_chain_begin_, solve_chain_row_, top_count_;
  std::deque<cholmod_common> thread_common_;  // a deque: started commons must not move
  // the separator's Schur complement (analyzeTop): its first row m, or -1
  int top_first_ = -1;
  // L21 by rows (row a: the sides' columns top_column_[top_begin_[a] ..], increasing), its
  // values and those times D1
  std::vector<int> top_begin_, top_column_;
  std::vector<double> top_l_, top_u_;
  // L21 by columns: side column i's separator rows column_row_[column_begin_[i] ..],
  // increasing, and where each is in the rows above
  std::vector<int> column_begin_, column_row_, column_position_;
  // L22's pattern by columns: column b's rows below the diagonal, increasing
  std::vector<int> separator_begin_, separator_row_;
  std::vector<double> schur_, schur_u_, pivot_;  // S, then L22 and L22 D2 (row-major), D2
  std::vector<std::vector<double>> scatter_;     // each thread's dense row of the sides
};

}  // namespace

struct SparseCholesky::Factor : CholmodFactor {};

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
