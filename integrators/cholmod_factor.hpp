#pragma once
// The CHOLMOD state behind SparseCholesky (sparse_cholesky.hpp), internal to integrators/. Its
// members are defined by what they do: sparse_cholesky.cpp (ordering, symbolic and numeric
// factorization, solves), elimination_tree_split.cpp (the split of the elimination tree over
// threads) and separator_schur.cpp (a dissected matrix's separator by its Schur complement).
#include <cholmod.h>

#include <atomic>
#include <deque>
#include <memory>
#include <utility>
#include <vector>

#include "integrators/nested_dissection.hpp"

namespace sweep {
namespace detail {

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
  CholmodFactor();
  ~CholmodFactor();
  CholmodFactor(const CholmodFactor&) = delete;
  CholmodFactor& operator=(const CholmodFactor&) = delete;

  void release();

  // The ordering (AMD, on A + A^T) and the symbolic factorization of the n x n matrix whose
  // lower triangle has the compressed columns (begin, row), rows sorted; kept when the
  // pattern is the last one's. The split for `threads` threads is made here too.
  bool analyze(int n, const std::vector<int>& begin, const std::vector<int>& row, int threads);
  // the numeric factorization of the matrix with these values (in the order of `row`)
  bool factorize(const std::vector<double>& value);
  int threads() const;
  // solution = A^-1 rhs: L y = P rhs, then L^T (P solution) = D^-1 y, on the factor's columns.
  // Split as the factorization is: a subtree row's y takes terms only from its own subtree's
  // columns, so the subtrees' columns run at once, each on its chain's thread, leaving out their
  // entries in the top's rows; then one pass over every column's entries in the top's rows, in
  // column order, completes those. Every y_i subtracts its terms in increasing column order and
  // every x_j its terms in increasing row order, as a plain column-by-column solve does: the
  // same bits for every split.
  void solve(const std::vector<double>& rhs, std::vector<double>& solution);

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
  void analyzeTop(int separator);

  bool factorizeTop();

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
  bool schedule(int threads);

  // subtree_work_ and the children lists (child_begin_, child_) of the elimination tree
  void measureSubtrees();

  // thread h's runs: each after the other threads' tasks it reads, then its rows by rowfac,
  // on a copy of the factor's header (rowfac records a zero pivot in its `minor`, which the
  // threads would otherwise share; the arrays are shared, each row writes only its subtree's
  // columns, and no column grows past the count the analysis gave it, so rowfac never
  // reallocates them under the other threads)
  void runTasks(int h, double* beta, std::atomic<bool>& failed);

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
  double assignTasks(int threads);

  // Each thread's runs (its tasks in the order they were given to it; a run ends before a task
  // that waits on another thread's), the rows' links within each run, and the solve's split:
  // the rows of whole-subtree tasks by their thread, the others (the top's) after them
  void buildRuns(int threads);

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

}  // namespace detail
}  // namespace sweep
