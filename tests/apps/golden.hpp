#pragma once
// Golden files of the regression runs: one value of q per line, 17 digits. With
// SWEEP_UPDATE_GOLDEN=1 set, rewriteGolden writes the file and the test skips itself (say why
// in the commit).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <limits>
#include <string>
#include <vector>

#include "framework/data.hpp"

namespace sweep::test {

// true when SWEEP_UPDATE_GOLDEN asked for the file to be rewritten (and it was)
inline bool rewriteGolden(const std::string& path, const VectorX& q) {
  if (std::getenv("SWEEP_UPDATE_GOLDEN") == nullptr) return false;
  std::ofstream out(path);
  out << std::setprecision(17);
  for (int i = 0; i < q.size(); ++i) out << q[i] << "\n";
  return true;
}

// the largest |q_i - stored_i| over the indices `compared(i)` keeps; a missing file or one of
// another size is a test failure and gives infinity
template <class Compared>
double goldenDifference(const std::string& path, const VectorX& q, Compared&& compared) {
  std::ifstream in(path);
  std::vector<double> stored;
  for (double x; in >> x;) stored.push_back(x);
  if (!in.eof() || static_cast<int>(stored.size()) != q.size()) {
    ADD_FAILURE() << path << ": " << stored.size() << " values for " << q.size();
    return std::numeric_limits<double>::infinity();
  }
  double worst = 0.0;
  for (int i = 0; i < q.size(); ++i)
    if (compared(i)) worst = std::max(worst, std::abs(q[i] - stored[i]));
  return worst;
}

}  // namespace sweep::test
