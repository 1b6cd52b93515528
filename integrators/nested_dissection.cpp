// One level of nested dissection for the sparse Cholesky factorization (nested_dissection.hpp).
#include "integrators/nested_dissection.hpp"

#include <mutex>

#include "framework/parallel.hpp"

namespace sweep {

bool DissectionOrdering::order(int n, std::vector<int>& begin, std::vector<int>& row, int threads,
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
    ordered[s] = cholmod_camd(&lower, nullptr, 0, side_constraint_[s].data(), side_order_[s].data(),
                              &common_[s]);
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

}  // namespace sweep
