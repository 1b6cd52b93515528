// The split of a CHOLMOD factorization over threads along its elimination tree: subtrees as
// tasks, list-scheduled (HEFT) onto the threads, each thread's runs and waits, and the
// triangular solves' split that follows from it (cholmod_factor.hpp says why it keeps the bits).
#include <algorithm>
#include <atomic>
#include <limits>
#include <thread>

#include "integrators/cholmod_factor.hpp"

namespace sweep {
namespace detail {

bool CholmodFactor::schedule(int threads) {
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

void CholmodFactor::measureSubtrees() {
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

void CholmodFactor::runTasks(int h, double* beta, std::atomic<bool>& failed) {
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

double CholmodFactor::assignTasks(int threads) {
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

void CholmodFactor::buildRuns(int threads) {
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

}  // namespace detail
}  // namespace sweep
