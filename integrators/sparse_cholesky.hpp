#pragma once
// A sparse Cholesky (LDL^T) factorization for the active-set Newton solver
// (integrators/projected_newton.hpp), on SuiteSparse CHOLMOD's simplicial factorization:
//   - analyze: the fill-reducing ordering of the n x n matrix whose lower triangle has the
//     compressed columns (begin, row), rows sorted (AMD; from 4096 rows one level of nested
//     dissection: METIS's vertex separator last, CAMD on each side), its symbolic
//     factorization, and the split of the elimination tree over `threads` threads. A pattern
//     equal to the last one's keeps all of it.
//   - factorize: the numeric factorization of the values on that pattern; false when the
//     matrix is not positive definite.
//   - solve: L D L^T x = rhs.
// Rows in disjoint subtrees of the elimination tree are factorized at once, list-scheduled
// onto the threads (HEFT: Topcuoglu, Hariri & Wu 2002), and a dissected matrix's separator by
// its Schur complement, dense: L21 D1 = A21 L11^-T, S = A22 - L21 D1 L21^T = L22 D2 L22^T. Every
// entry's arithmetic is the same whichever thread computes it: the same bits for every thread
// count. No call allocates once a pattern is analysed.
#include <memory>
#include <vector>

namespace sweep {

class SparseCholesky {
 public:
  SparseCholesky();
  ~SparseCholesky();
  SparseCholesky(const SparseCholesky&) = delete;
  SparseCholesky& operator=(const SparseCholesky&) = delete;

  bool analyze(int n, const std::vector<int>& begin, const std::vector<int>& row, int threads);
  bool factorize(const std::vector<double>& value);
  void solve(const std::vector<double>& rhs, std::vector<double>& solution);
  // the threads the last pattern's factorization is split over (1: CHOLMOD's own, unsplit)
  int threads() const;

 private:
  struct Factor;  // CHOLMOD's state (cholmod_factor.hpp)
  std::unique_ptr<Factor> factor_;
};

}  // namespace sweep
