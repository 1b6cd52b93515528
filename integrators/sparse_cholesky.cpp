// A sparse Cholesky factorization on CHOLMOD, for the active-set Newton solver
// (integrators/projected_newton.hpp): the fill-reducing ordering (AMD; from 4096 rows one level
// of nested dissection), the symbolic and numeric factorization, kept between solves, split
// along the elimination tree on threads, and the triangular solves, with the same bits for
// every thread count.
#include "integrators/sparse_cholesky.hpp"

#include <cholmod.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <mutex>
#include <queue>
#include <utility>

#include "framework/parallel.hpp"

namespace sweep {

namespace {

void startCommon(cholmod_common& common) {
  cholmod_start(&common);
  common.print = 0;
  common.error_handler = nullptr;
}

// a CHOLMOD view of an n x n matrix's compressed columns (begin, row), rows sorted (values
// null: the pattern alone; stype -1: the lower triangle of a symmetric one, 1: the upper)
cholmod_sparse sparseView(int n, std::vector<int>& begin, std::vector<int>& row, double* value,
                          int stype) {
  cholmod_sparse m{};
  m.nrow = m.ncol = static_cast<size_t>(n);
  m.nzmax = row.size();
  m.p = begin.data();
  m.i = row.data();
  m.x = value;
  m.stype = stype;
  m.itype = CHOLMOD_INT;
  m.xtype = value != nullptr ? CHOLMOD_REAL : CHOLMOD_PATTERN;
  m.dtype = CHOLMOD_DOUBLE;
  m.sorted = 1;
  m.packed = 1;
  return m;
}

// The fill-reducing order of a large matrix: one level of nested dissection, constrained
// minimum degree below it. METIS's vertex separator (Karypis & Kumar 1998, "A fast and high
// quality multilevel scheme for partitioning irregular graphs", SIAM J. Sci. Comput. 20; by
// CHOLMOD's cholmod_bisect) splits the matrix's graph into two sides that no entry joins; each
// side is ordered by CAMD on its own graph with the separator, the separator held last (Davis's
// constrained AMD: the side's degrees count the separator's fill, as one CAMD over the whole
// matrix would); the two run at once on two threads; the separator's rows come last. The
// elimination tree becomes two disjoint trees under the separator's rows, where AMD alone ends
// its trees of contact networks in a long chain of rows that no thread can share (docs/
// architecture.md, "Threads are OpenMP"). The fill stays AMD's. METIS seeds its
// generator with a fixed seed and runs on one thread: the order does not depend on the thread
// count.
class DissectionOrdering {
 public:
  DissectionOrdering() {
    for (cholmod_common& c : common_) startCommon(c);
  }
  ~DissectionOrdering() {
    for (cholmod_common& c : common_) cholmod_finish(&c);
  }
  DissectionOrdering(const DissectionOrdering&) = delete;
  DissectionOrdering& operator=(const DissectionOrdering&) = delete;

  // permutation[k]: the row eliminated k-th, of the n x n matrix whose lower triangle has the
  // compressed columns (begin, row), rows sorted
  bool order(int n, std::vector<int>& begin, std::vector<int>& row, int threads,
             std::vector<int>& permutation) {
    cholmod_sparse whole = sparseView(n, begin, row, nullptr, -1);
    part_.resize(n);
    {
      // METIS re-seeds one process-wide generator at each call: two at once (two simulations on
      // two threads, as Python may run them) would draw from each other's sequence
      static std::mutex metis;
      const std::lock_guard<std::mutex> lock(metis);
      // compress: nodes of equal adjacency merged before METIS sees the graph
      if (cholmod_bisect(&whole, nullptr, 0, 1, part_.data(), &common_[0]) < 0) return false;
    }
    // each side's graph with the separator (CAMD's constraint set 1), numbered in the matrix's
    // order
    local_.resize(n);
    for (int s = 0; s < 2; ++s) {
      std::vector<int>& nodes = side_node_[s];
      nodes.clear();
      for (int v = 0; v < n; ++v) {
        local_[v] = -1;
        if (part_[v] == s || part_[v] == kSeparator) {
          local_[v] = static_cast<int>(nodes.size());
          nodes.push_back(v);
        }
      }
      side_begin_[s].assign(1, 0);
      side_row_[s].clear();
      side_constraint_[s].clear();
      for (int v : nodes) {
        for (int e = begin[v]; e < begin[v + 1]; ++e)
          if (local_[row[e]] >= 0) side_row_[s].push_back(local_[row[e]]);
        side_begin_[s].push_back(static_cast<int>(side_row_[s].size()));
        side_constraint_[s].push_back(part_[v] == kSeparator ? 1 : 0);
      }
      side_order_[s].resize(nodes.size());
    }
    int ordered[2] = {1, 1};
    parallelFor(2, std::min(threads, 2), [&](int s) {
      const int m = static_cast<int>(side_node_[s].size());
      if (m == 0) return;
      cholmod_sparse lower = sparseView(m, side_begin_[s], side_row_[s], nullptr, -1);
      ordered[s] = cholmod_camd(&lower, nullptr, 0, side_constraint_[s].data(),
                                side_order_[s].data(), &common_[s]);
    });
    if (!ordered[0] || !ordered[1]) return false;
    // side 0, side 1, then the separator in side 0's order (the whole of it when side 0 is
    // empty: then side_node_[0] is the separator)
    permutation.clear();
    for (int s = 0; s < 2; ++s)
      for (int k : side_order_[s])
        if (part_[side_node_[s][k]] == s) permutation.push_back(side_node_[s][k]);
    for (int k : side_order_[0])
      if (part_[side_node_[0][k]] == kSeparator) permutation.push_back(side_node_[0][k]);
    return static_cast<int>(permutation.size()) == n;
  }

 private:
  static constexpr int kSeparator = 2;  // cholmod_bisect's mark of the separator's nodes

  std::vector<int> part_, local_;
  std::vector<int> side_node_[2], side_begin_[2], side_row_[2], side_constraint_[2], side_order_[2];
  cholmod_common common_[2]{};  // one per side: the two orderings run at once
};

// CHOLMOD's common block, the fill-reducing permutation, the matrix permuted into CHOLMOD's
// own working form and the symbolic and numeric factor, all kept between solves. The matrix
// is permuted here, once per pattern, so that each numeric factorization reads it in place:
// CHOLMOD's simplicial factorization of a matrix with a permutation would build a transposed,
// permuted copy every time (an allocation inside the solver's iterations and, measured, 7 % of
// the 500-disk funnel's run). A pattern equal to the last one's reuses all of it.
//
// On threads, the factorization is CHOLMOD's own up-looking one (cholmod_rowfac), split along
// the elimination tree: row k of L reads only the rows of k's descendants, so disjoint subtrees
// are factorized at once, each on its own thread with its own CHOLMOD workspace, and the rows
// above them (the tree's top) after, on one thread. Each row is computed by the same arithmetic
// as in the one-thread factorization, from the same rows before it: the factor has the same
// bits for every thread count. The subtrees are chosen as Geist & Ng's (1989, "Task scheduling
// for parallel sparse Cholesky factorization", Int. J. Parallel Program. 18): the heaviest one
// split into its children until they pack evenly onto the threads (work: each row's
// multiply-adds, counted on the elimination tree).
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
    if (n < kParallelRows) {
      if (!cholmod_amd(&lower, nullptr, 0, permutation_.data(), &common_)) return false;
    } else if (!dissection_.order(n, begin_, row_, threads, permutation_)) {
      return false;
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
    return schedule(threads);
  }
  // the numeric factorization of the matrix with these values (in the order of `row`)
  bool factorize(const std::vector<double>& value) {
    for (std::size_t e = 0; e < value.size(); ++e) upper_value_[to_upper_[e]] = value[e];
    if (scheduled_threads_ <= 1) {
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
    const int threads = scheduled_threads_;
#pragma omp parallel num_threads(threads) reduction(&& : ok)
    {
      // chain by chain, however many threads the runtime gives
      for (int chain = omp_get_thread_num(); chain < threads; chain += omp_get_num_threads()) {
        if (chain_start_[chain] >= n_) continue;
        // a copy of the factor's header: rowfac records a zero pivot in its `minor`, which the
        // threads would otherwise share; the arrays are shared, each chain's rows write only
        // the columns of its own subtrees, and no column grows (each holds the count the
        // analysis gave it), so rowfac never reallocates them under the other threads
        cholmod_factor own = *factor_;
        ok = cholmod_rowfac_mask(&upper_, nullptr, beta, chain_start_[chain], n_, nullptr,
                                 link_.data(), &own, &thread_common_[chain]) &&
             own.minor == own.n && ok;
      }
    }
    if (!ok) return false;
    if (chain_start_[threads] < n_ &&
        !cholmod_rowfac_mask(&upper_, nullptr, beta, chain_start_[threads], n_, nullptr,
                             link_.data(), factor_, &common_))
      return false;
    return common_.status == CHOLMOD_OK && factor_->minor == factor_->n;
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
  // matrices with fewer rows are ordered by AMD alone and factorized on one thread: the split
  // would cost more than it gains
  static constexpr int kParallelRows = 4096;
  // subtrees are packed onto threads once the heaviest is within this factor of a thread's share
  static constexpr double kBalance = 1.05;
  // packings tried at most (each O(subtrees log subtrees))
  static constexpr int kMaxPackings = 64;
  // a split is used when its estimated time is below this fraction of one thread's
  static constexpr double kWorthwhile = 0.9;

  // The rows each thread factorizes (chains through link_, from chain_start_[t]; the top's
  // chain from chain_start_[threads]), each chain in increasing row order. One thread, or a
  // split that leaves no two subtrees, factorizes as CHOLMOD does (scheduled_threads_ = 1).
  bool schedule(int threads) {
    threads = std::max(1, threads);
    if (threads == requested_threads_) return true;
    requested_threads_ = threads;
    scheduled_threads_ = 1;
    if (threads == 1 || n_ < kParallelRows) return true;
    const int n = n_;
    measureSubtrees();
    const double all = subtree_work_total_;
    const double best_time = chooseSubtrees(threads);
    // a split worth its threads: a tenth off the time at least
    if (best_time > kWorthwhile * all) return true;
    buildChains(threads);
    // each thread's own workspace, sized here, outside the factorizations
    while (static_cast<int>(thread_common_.size()) < threads) {
      thread_common_.emplace_back();
      startCommon(thread_common_.back());
    }
    for (int t = 0; t < threads; ++t)
      if (!cholmod_allocate_work(n, n, n, &thread_common_[t])) return false;
    if (!cholmod_allocate_work(n, n, n, &common_)) return false;
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

  // The subtrees each thread factorizes (best_roots_, best_owner_); returns the estimated time
  // of that split
  double chooseSubtrees(int threads) {
    const int n = n_;
    // Geist & Ng: split the heaviest subtree (its root joins the top) while it exceeds a
    // thread's share; from there on, pack the subtrees onto the threads (the longest first, each
    // to the least loaded thread) and keep the split whose estimated time, the top's work plus
    // the most loaded thread's, is least; stop once the top alone costs more
    using Item = std::pair<double, int>;
    std::priority_queue<Item> heap;
    double total = 0.0;  // the work in the heap's subtrees
    for (int e = child_begin_[n]; e < child_begin_[n + 1]; ++e) {
      heap.push({subtree_work_[child_[e]], child_[e]});
      total += subtree_work_[child_[e]];
    }
    const double all = total;
    double best_time = all;
    best_roots_.clear();
    best_owner_.clear();
    for (int packings = 0; !heap.empty() && packings < kMaxPackings && all - total < best_time;) {
      const Item top = heap.top();
      if (top.first * threads <= total * kBalance) {
        ++packings;
        std::priority_queue<Item> copy = heap;
        load_.assign(threads, 0.0);
        packed_roots_.clear();
        packed_owner_.clear();
        while (!copy.empty()) {
          const int t =
              static_cast<int>(std::min_element(load_.begin(), load_.end()) - load_.begin());
          load_[t] += copy.top().first;
          packed_roots_.push_back(copy.top().second);
          packed_owner_.push_back(t);
          copy.pop();
        }
        const double time = all - total + *std::max_element(load_.begin(), load_.end());
        if (time < best_time) {
          best_time = time;
          best_roots_.swap(packed_roots_);
          best_owner_.swap(packed_owner_);
        }
      }
      const int root = top.second;
      if (child_begin_[root + 1] == child_begin_[root]) break;  // a leaf: nothing to split
      heap.pop();
      total -= top.first;
      for (int e = child_begin_[root]; e < child_begin_[root + 1]; ++e) {
        heap.push({subtree_work_[child_[e]], child_[e]});
        total += subtree_work_[child_[e]];
      }
    }
    return best_time;
  }

  // Each row's owner, the factorization's and the solve's chains, and each column's entries
  // in the top's rows, for the split chosen
  void buildChains(int threads) {
    const int n = n_;
    // owners downwards: a chosen root's subtree is its thread's, every other row the top's
    owner_.assign(n, -2);
    for (std::size_t r = 0; r < best_roots_.size(); ++r) owner_[best_roots_[r]] = best_owner_[r];
    for (int j = n - 1; j >= 0; --j)
      if (owner_[j] == -2) owner_[j] = parent_[j] >= 0 ? owner_[parent_[j]] : -1;
    // the chains, in increasing row order (descendants before ancestors); the top's is chain
    // `threads`
    auto chainOf = [&](int j) { return owner_[j] >= 0 ? owner_[j] : threads; };
    chain_start_.assign(threads + 1, n);
    link_.assign(n, n);
    std::vector<int> last(threads + 1, -1);
    for (int j = 1; j < n; ++j) {  // row 0 is factorized alone, before the chains
      const int chain = chainOf(j);
      if (last[chain] < 0)
        chain_start_[chain] = j;
      else
        link_[last[chain]] = j;
      last[chain] = j;
    }
    // the solve's chains (row 0 in its owner's), and the entries of each column in the top's
    // rows: the last ones of the column, the top's rows coming after its subtree's (a column's
    // rows are its ancestors, increasing up the tree)
    solve_chain_begin_.assign(threads + 3, 0);
    for (int j = 0; j < n; ++j) ++solve_chain_begin_[chainOf(j) + 2];
    for (int c = 0; c <= threads; ++c) solve_chain_begin_[c + 2] += solve_chain_begin_[c + 1];
    solve_chain_row_.resize(n);
    for (int j = 0; j < n; ++j) solve_chain_row_[solve_chain_begin_[chainOf(j) + 1]++] = j;
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
  std::vector<int> parent_, child_begin_, child_, owner_, chain_start_, link_;
  // the solve's split: chain c's rows from solve_chain_begin_[c] (the top's: c = threads), and
  // each column's entries in the top's rows
  std::vector<int> solve_chain_begin_, solve_chain_row_, top_count_;
  std::vector<int> best_roots_, best_owner_, packed_roots_, packed_owner_;
  std::vector<double> subtree_work_, load_;
  double subtree_work_total_ = 0.0;           // the roots' subtree work: all the work
  std::deque<cholmod_common> thread_common_;  // a deque: started commons must not move
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
