#pragma once
// The sparse Cholesky factorization's ordering (integrators/sparse_cholesky.cpp): one level of
// nested dissection for large matrices, and the CHOLMOD helpers both files use.
#include <cholmod.h>

#include <algorithm>
#include <vector>

namespace sweep {

inline void startCommon(cholmod_common& common) {
  cholmod_start(&common);
  common.print = 0;
  common.error_handler = nullptr;
}

// a CHOLMOD view of an n x n matrix's compressed columns (begin, row), rows sorted (values
// null: the pattern alone; stype -1: the lower triangle of a symmetric one, 1: the upper)
inline cholmod_sparse sparseView(int n, std::vector<int>& begin, std::vector<int>& row,
                                 double* value, int stype) {
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
             std::vector<int>& permutation);
  // the rows of the last order's separator (the permutation's last ones)
  int separatorRows() const {
    return static_cast<int>(std::count(part_.begin(), part_.end(), kSeparator));
  }

 private:
  static constexpr int kSeparator = 2;  // cholmod_bisect's mark of the separator's nodes

  std::vector<int> part_, local_;
  std::vector<int> side_node_[2], side_begin_[2], side_row_[2], side_constraint_[2], side_order_[2];
  cholmod_common common_[2]{};  // one per side: the two orderings run at once
};

}  // namespace sweep
