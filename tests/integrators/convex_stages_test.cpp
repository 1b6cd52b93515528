// The convex solvers: MPRGP / MPGP on dense random programs against an independent solve
// (accelerated projected gradient), and scheme B's stages solved by them against NLGS.
#include "integrators/convex_stages.hpp"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdio>
#include <functional>
#include <random>
#include <thread>

#include "framework/parallel.hpp"
#include "integrators/mprgp.hpp"
#include "integrators/projected_newton.hpp"
#include "integrators/sparse_cholesky.hpp"
#include "solver_fixtures.hpp"

namespace sweep {
namespace {

// A = B^T B over "velocities" of size B.rows(), b given: toVelocity is B x, toGradient B^T v (+ b).
class DenseProgram final : public QpOperator {
 public:
  DenseProgram(MatrixX B, VectorX b) : B_(std::move(B)), b_(std::move(b)) {}
  const MatrixX& matrix() const { return B_; }
  void toVelocity(const std::vector<double>& x, VectorX& z) const override {
    z = B_ * Eigen::Map<const VectorX>(x.data(), static_cast<Eigen::Index>(x.size()));
  }
  void toGradient(const VectorX& v, bool affine, std::vector<double>& y) const override {
    VectorX g = B_.transpose() * v;
    if (affine) g += b_;
    for (Eigen::Index i = 0; i < g.size(); ++i) y[i] = g[i];
  }
  bool columns(SparseColumns& J, SparseColumns& K) const override {
    for (Eigen::Index j = 0; j < B_.cols(); ++j) {
      for (Eigen::Index i = 0; i < B_.rows(); ++i) {
        J.push(static_cast<int>(i), B_(i, j));
        K.push(static_cast<int>(i), B_(i, j));
      }
      J.endColumn();
      K.endColumn();
    }
    return true;
  }
  double objective(const std::vector<double>& x) const {
    const VectorX xv = Eigen::Map<const VectorX>(x.data(), static_cast<Eigen::Index>(x.size()));
    return 0.5 * (B_ * xv).squaredNorm() + b_.dot(xv);
  }
  const MatrixX& B() const { return B_; }
  const VectorX& b() const { return b_; }

 private:
  MatrixX B_;
  VectorX b_;
};

// The projection of one block, written out again for the reference solve.
void projectReference(const SeparableSet& s, std::vector<double>& x) {
  for (int k = 0; k < s.blocks(); ++k) {
    double* y = x.data() + s.first[k];
    switch (s.set[k]) {
      case BlockSet::Fixed:
        for (int i = 0; i < s.size[k]; ++i) y[i] = 0.0;
        break;
      case BlockSet::Free:
        break;
      case BlockSet::NonNegative:
        y[0] = std::max(y[0], 0.0);
        break;
      case BlockSet::Ball: {
        double norm = 0.0;
        for (int i = 0; i < s.size[k]; ++i) norm += y[i] * y[i];
        norm = std::sqrt(norm);
        if (norm > s.radius[k])
          for (int i = 0; i < s.size[k]; ++i) y[i] *= s.radius[k] / norm;
        break;
      }
    }
  }
}

// FISTA with restarts, run long: an answer reached by a different road.
// A random program over `set`: B with two rows more than variables (rows: velocities,
// columns: variables) and a linear term b. A redundant program repeats a column, so that two
// variables act identically (a contact detected twice); the free variables' linear term then
// lies in the range of A, for a bounded program.
DenseProgram randomProgram(std::mt19937& rng, const SeparableSet& set, bool redundant) {
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  const int n = set.variables;
  MatrixX B(n + 2, n);
  for (int i = 0; i < B.rows(); ++i)
    for (int j = 0; j < n; ++j) B(i, j) = uniform(rng);
  if (redundant) B.col(n - 1) = B.col(0);
  VectorX b(n);
  for (int j = 0; j < n; ++j) b[j] = 2.0 * uniform(rng);
  if (redundant) {
    for (int k = 0; k < set.blocks(); ++k)
      if (set.set[k] == BlockSet::Free) b[set.first[k]] = 0.0;
    b[n - 1] = b[0];
  }
  return DenseProgram(std::move(B), std::move(b));
}

std::vector<double> referenceSolve(const DenseProgram& program, const SeparableSet& s) {
  const MatrixX A = program.B().transpose() * program.B();
  const double L = Eigen::SelfAdjointEigenSolver<MatrixX>(A).eigenvalues().maxCoeff();
  const int n = static_cast<int>(A.rows());
  std::vector<double> x(n, 0.0), y(n, 0.0), x_old(n, 0.0);
  double t = 1.0;
  for (int it = 0; it < 200000; ++it) {
    const VectorX yv = Eigen::Map<VectorX>(y.data(), n);
    const VectorX g = A * yv + program.b();
    for (int i = 0; i < n; ++i) x[i] = y[i] - g[i] / L;
    projectReference(s, x);
    const double t_new = 0.5 * (1.0 + std::sqrt(1.0 + 4.0 * t * t));
    double restart = 0.0;
    for (int i = 0; i < n; ++i) restart += g[i] * (x[i] - x_old[i]);
    if (restart > 0.0) t = 1.0;  // O'Donoghue & Candes gradient restart
    const double momentum = restart > 0.0 ? 0.0 : (t - 1.0) / t_new;
    for (int i = 0; i < n; ++i) y[i] = x[i] + momentum * (x[i] - x_old[i]);
    x_old = x;
    t = restart > 0.0 ? 1.0 : t_new;
  }
  return x;
}

// `blocks` blocks of every kind in turn (>= 0, free, an interval, a disc, fixed or a ball of
// radius 0), random radii
SeparableSet setOfEveryKind(std::mt19937& rng, int trial, int blocks) {
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  SeparableSet set;
  for (int k = 0; k < blocks; ++k) {
    switch ((trial + k) % 5) {
      case 0:
        set.add(BlockSet::NonNegative, 1);
        break;
      case 1:
        set.add(BlockSet::Free, 1);
        break;
      case 2:
        set.add(BlockSet::Ball, 1, 0.3 + 0.5 * std::abs(uniform(rng)));
        break;
      case 3:
        set.add(BlockSet::Ball, 2, 0.3 + 0.5 * std::abs(uniform(rng)));
        break;
      default:
        set.add(k % 2 ? BlockSet::Fixed : BlockSet::Ball, 2, 0.0);
    }
  }
  return set;
}

// Random programs of every block kind, with duplicated rows (A singular) in half of them.
TEST(Mprgp, RandomProgramsMatchAnIndependentSolve) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  int worst_iterations[2] = {0, 0};
  for (int trial = 0; trial < 60; ++trial) {
    const SeparableSet set = setOfEveryKind(rng, trial, 3 + trial % 5);
    const int n = set.variables;
    const DenseProgram program = randomProgram(rng, set, trial % 2 == 1);
    const MatrixX& B = program.matrix();
    const std::vector<double> reference = referenceSolve(program, set);
    const double f_ref = program.objective(reference);
    const VectorX v_ref = B * Eigen::Map<const VectorX>(reference.data(), n);
    // solveSeparableQp picks MPRGP for boxes and APGD for discs; APGD is also run on boxes
    for (bool apgd : {false, true}) {
      MprgpSettings settings;
      settings.tolerance = 1e-12;
      settings.max_iterations = 5000;
      std::vector<double> x(n, 0.0);
      VectorX v = VectorX::Zero(B.rows());
      MprgpWorkspace ws;
      const MprgpStats stats = apgd ? solveApgd(program, set, settings, x, v, ws)
                                    : solveSeparableQp(program, set, settings, x, v, ws);
      ASSERT_TRUE(stats.converged)
          << "trial " << trial << " apgd " << apgd << " residual " << stats.residual;
      worst_iterations[apgd] = std::max(worst_iterations[apgd], stats.iterations);
      // feasible, v consistent with x, and the objective and the velocities of the reference
      std::vector<double> projected = x;
      projectReference(set, projected);
      for (int i = 0; i < n; ++i) EXPECT_NEAR(projected[i], x[i], 1e-12) << trial;
      const VectorX xv = Eigen::Map<VectorX>(x.data(), n);
      EXPECT_LT((v - B * xv).norm(), 1e-12 * (1.0 + v.norm())) << trial;
      const double f = program.objective(x);
      EXPECT_LE(f, f_ref + 1e-10 * (1.0 + std::abs(f_ref))) << trial;
      EXPECT_LT((v - v_ref).norm(), 1e-6 * (1.0 + v_ref.norm())) << trial;
    }
  }
  std::printf(
      "random programs to 1e-12: at most %d iterations (MPRGP or APGD by the sets), %d "
      "(APGD)\n",
      worst_iterations[0], worst_iterations[1]);
}

// A solve's answer x (v: its velocity) against the reference: feasible, v = B x, an objective no
// higher than the reference's, and the reference's velocities
void expectTheReferenceAnswer(const DenseProgram& program, const SeparableSet& set,
                              const std::vector<double>& reference, const std::vector<double>& x,
                              const VectorX& v, int trial) {
  const int n = set.variables;
  const MatrixX& B = program.matrix();
  const double f_ref = program.objective(reference);
  const VectorX v_ref = B * Eigen::Map<const VectorX>(reference.data(), n);
  std::vector<double> projected = x;
  projectReference(set, projected);
  for (int i = 0; i < n; ++i) EXPECT_NEAR(projected[i], x[i], 1e-12) << trial;
  const VectorX xv = Eigen::Map<const VectorX>(x.data(), n);
  EXPECT_LT((v - B * xv).norm(), 1e-12 * (1.0 + v.norm())) << trial;
  EXPECT_LE(program.objective(x), f_ref + 1e-10 * (1.0 + std::abs(f_ref))) << trial;
  EXPECT_LT((v - v_ref).norm(), 1e-6 * (1.0 + v_ref.norm())) << trial;
}

// Random programs of every block kind (>= 0, free, intervals, discs, fixed, balls of radius 0),
// a duplicated column in half of them. To 1e-7 the interior-point iterations reach the
// reference by themselves, in a count that does not grow with the program's size; to 1e-12 the
// last digits are MPRGP's / APGD's from the interior-point answer (an interior iterate's
// natural-map residual falls like the square root of the gap on a disc's boundary,
// interior_point.hpp), and the answer is the reference's.
TEST(InteriorPoint, RandomProgramsMatchAnIndependentSolve) {
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  int worst_alone = 0, worst_polish = 0;
  for (int trial = 0; trial < 80; ++trial) {
    const SeparableSet set = setOfEveryKind(rng, trial, 3 + trial % 9);
    ASSERT_TRUE(interiorPointApplies(set));
    const int n = set.variables;
    const DenseProgram program = randomProgram(rng, set, trial % 2 == 1);
    const MatrixX& B = program.matrix();
    const std::vector<double> reference = referenceSolve(program, set);
    const double f_ref = program.objective(reference);
    const VectorX v_ref = B * Eigen::Map<const VectorX>(reference.data(), n);
    for (double tolerance : {1e-7, 1e-12}) {
      MprgpSettings settings;
      settings.tolerance = tolerance;
      settings.max_iterations = 5000;
      std::vector<double> x(n, 0.0);
      VectorX v = VectorX::Zero(B.rows());
      ProjectedNewtonWorkspace newton;
      InteriorPointWorkspace ws;
      MprgpWorkspace fallback;
      const MprgpStats stats =
          solveInteriorPoint(program, set, settings, x, v, newton, ws, fallback);
      ASSERT_TRUE(stats.converged) << "trial " << trial << " residual " << stats.residual;
      if (tolerance == 1e-7) {
        EXPECT_EQ(stats.newton_steps, stats.iterations) << "handed over, trial " << trial;
        worst_alone = std::max(worst_alone, stats.iterations);
        continue;
      }
      worst_polish = std::max(worst_polish, stats.iterations - stats.newton_steps);
      std::vector<double> projected = x;
      projectReference(set, projected);
      for (int i = 0; i < n; ++i) EXPECT_NEAR(projected[i], x[i], 1e-12) << trial;
      const VectorX xv = Eigen::Map<VectorX>(x.data(), n);
      EXPECT_LT((v - B * xv).norm(), 1e-12 * (1.0 + v.norm())) << trial;
      EXPECT_LE(program.objective(x), f_ref + 1e-10 * (1.0 + std::abs(f_ref))) << trial;
      EXPECT_LT((v - v_ref).norm(), 1e-6 * (1.0 + v_ref.norm())) << trial;
    }
  }
  EXPECT_LE(worst_alone, 30);
  std::printf(
      "random programs: at most %d interior-point iterations to 1e-7, then at most %d of "
      "MPRGP / APGD to 1e-12\n",
      worst_alone, worst_polish);
}

// Random box programs (>= 0, free, intervals, fixed), a duplicated column in half of them:
// projected Newton's active-set steps reach the reference, by themselves (no MPRGP hand-over).
TEST(ProjectedNewton, RandomBoxProgramsMatchAnIndependentSolve) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  int worst = 0;
  for (int trial = 0; trial < 80; ++trial) {
    SeparableSet set;
    const int blocks = 3 + trial % 9;
    for (int k = 0; k < blocks; ++k) {
      switch ((trial + k) % 4) {
        case 0:
          set.add(BlockSet::NonNegative, 1);
          break;
        case 1:
          set.add(BlockSet::Free, 1);
          break;
        case 2:
          set.add(BlockSet::Ball, 1, 0.3 + 0.5 * std::abs(uniform(rng)));
          break;
        default:
          set.add(k % 2 ? BlockSet::Fixed : BlockSet::NonNegative, 1);
      }
    }
    ASSERT_TRUE(projectedNewtonApplies(set));
    const int n = set.variables;
    const DenseProgram program = randomProgram(rng, set, trial % 2 == 1);
    const std::vector<double> reference = referenceSolve(program, set);
    MprgpSettings settings;
    settings.tolerance = 1e-12;
    settings.max_iterations = 5000;
    std::vector<double> x(n, 0.0);
    VectorX v = VectorX::Zero(program.matrix().rows());
    ProjectedNewtonWorkspace ws;
    MprgpWorkspace fallback;
    const MprgpStats stats = solveProjectedNewton(program, set, settings, x, v, ws, fallback);
    ASSERT_TRUE(stats.converged) << "trial " << trial << " residual " << stats.residual;
    worst = std::max(worst, stats.iterations);
    expectTheReferenceAnswer(program, set, reference, x, v, trial);
    // warm-started from its own answer, one step keeps it
    const std::vector<double> answer = x;
    std::fill(x.begin(), x.end(), 0.0);
    x = answer;
    v.setZero();
    const MprgpStats again = solveProjectedNewton(program, set, settings, x, v, ws, fallback);
    EXPECT_TRUE(again.converged);
    EXPECT_EQ(again.iterations, 1) << trial;
  }
  std::printf("random box programs to 1e-12: at most %d projected Newton steps\n", worst);
}

// A column of touching grains at rest on a floor, all falling at the same speed: only the floor
// row approaches (b < 0), every row above it sits on its bound with zero gradient. The face
// taken must free those rows (x - g = 0 stays in the box): held, they would be freed one grain a
// step, as many steps as the column is tall. The answer: each row carries the grains above it.
TEST(ProjectedNewton, AColumnAtRestClosesInOneFaceNotOneRowAStep) {
  const int grains = 60;
  const double fall = 9.81e-4;                // g h
  MatrixX B = MatrixX::Zero(grains, grains);  // row k: grain k's velocity; column j: contact j
  B(0, 0) = 1.0;                              // the floor pushes grain 0 up
  for (int j = 1; j < grains; ++j) {          // contact j pushes grain j up, grain j - 1 down
    B(j, j) = 1.0;
    B(j - 1, j) = -1.0;
  }
  const VectorX v_free = VectorX::Constant(grains, -fall);
  const VectorX b = B.transpose() * v_free;
  const DenseProgram program(B, b);
  SeparableSet set;
  for (int j = 0; j < grains; ++j) set.add(BlockSet::NonNegative, 1);
  MprgpSettings settings;
  settings.tolerance = 1e-12;
  std::vector<double> x(grains, 0.0);
  VectorX v = VectorX::Zero(grains);
  ProjectedNewtonWorkspace ws;
  MprgpWorkspace fallback;
  const MprgpStats stats = solveProjectedNewton(program, set, settings, x, v, ws, fallback);
  ASSERT_TRUE(stats.converged) << stats.residual;
  EXPECT_EQ(stats.newton_steps, stats.iterations) << "handed over";
  // the proximal term's contraction on the column's softest mode sets the count, not its height
  EXPECT_LE(stats.newton_steps, grains / 4);
  for (int j = 0; j < grains; ++j)
    EXPECT_NEAR(x[j], (grains - j) * fall, 1e-7 * grains * fall) << "contact " << j;
  std::printf("a column of %d grains at rest: %d Newton steps\n", grains, stats.newton_steps);
}

// the discs' radius in the threads test: some stick, some slide
constexpr double kDiscRadius = 1.0;

// Random programs of every block kind, discs included (3D stage 5b), a duplicated column in
// half of them: the semismooth steps on the discs' natural map, in each sliding disc's frame,
// reach the reference by themselves (no hand-over), to 1e-12.
TEST(ProjectedNewton, RandomDiscProgramsMatchAnIndependentSolve) {
  std::mt19937 rng(17);
  int worst = 0;
  for (int trial = 0; trial < 80; ++trial) {
    const SeparableSet set = setOfEveryKind(rng, trial, 3 + trial % 9);
    ASSERT_TRUE(projectedNewtonApplies(set));
    const int n = set.variables;
    const DenseProgram program = randomProgram(rng, set, trial % 2 == 1);
    const std::vector<double> reference = referenceSolve(program, set);
    MprgpSettings settings;
    settings.tolerance = 1e-12;
    settings.max_iterations = 5000;
    std::vector<double> x(n, 0.0);
    VectorX v = VectorX::Zero(program.matrix().rows());
    ProjectedNewtonWorkspace ws;
    MprgpWorkspace fallback;
    const MprgpStats stats = solveProjectedNewton(program, set, settings, x, v, ws, fallback);
    ASSERT_TRUE(stats.converged) << "trial " << trial << " residual " << stats.residual;
    EXPECT_EQ(stats.newton_steps, stats.iterations) << "handed over, trial " << trial;
    worst = std::max(worst, stats.iterations);
    expectTheReferenceAnswer(program, set, reference, x, v, trial);
  }
  std::printf("random programs with discs to 1e-12: at most %d semismooth Newton steps\n", worst);
}

// The factorization split over threads along the elimination tree gives the same bits as one
// thread: the same iterates, the same answer, bit for bit, on 1, 2, 3 and 4 threads, and
// again on a second solve of the same pattern (the refactorization path).
TEST(ProjectedNewton, ThreadsGiveTheSameBits) {
  std::mt19937 rng(5);
  const test::NetworkProgram program = test::gridProgram(90, rng);  // 16 020 variables
  // the orthant (stage 5a), and discs over pairs of variables (3D stage 5b, in their frames)
  for (bool discs : {false, true}) {
    SeparableSet set;
    for (int j = 0; j < program.variables(); j += discs ? 2 : 1)
      set.add(discs ? BlockSet::Ball : BlockSet::NonNegative, discs ? 2 : 1, kDiscRadius);
    ASSERT_TRUE(projectedNewtonApplies(set));
    std::vector<double> x_one;
    VectorX v_one;
    const std::vector<int> counts = test::threadCounts();
    for (int threads : counts) {
      MprgpSettings settings;
      settings.tolerance = 1e-10;
      settings.threads = threads;
      ProjectedNewtonWorkspace ws;
      MprgpWorkspace fallback;
      for (int solve = 0; solve < 2; ++solve) {
        std::vector<double> x(program.variables(), 0.0);
        VectorX v = VectorX::Zero(program.velocities());
        const MprgpStats stats = solveProjectedNewton(program, set, settings, x, v, ws, fallback);
        ASSERT_TRUE(stats.converged) << threads << " threads, residual " << stats.residual;
        EXPECT_EQ(stats.newton_steps, stats.iterations) << "handed over on " << threads;
        // the split is taken: the bits below compare a split factorization with CHOLMOD's own
        EXPECT_EQ(ws.factorThreads(), threads);
        if (threads == counts[0] && solve == 0) {
          x_one = x;
          v_one = v;
          // both kinds of blocks (inside and on the bound), so that the active set matters
          int inside = 0;
          for (int b = 0; b < set.blocks(); ++b) {
            const double* xb = x.data() + set.first[b];
            inside += discs ? std::hypot(xb[0], xb[1]) < kDiscRadius * (1.0 - 1e-9) : xb[0] > 0.0;
          }
          std::printf("%s: %d of %d blocks inside, %d Newton steps\n", discs ? "discs" : "orthant",
                      inside, set.blocks(), stats.iterations);
          EXPECT_GT(inside, set.blocks() / 10);
          EXPECT_LT(inside, set.blocks() * 9 / 10);
          continue;
        }
        EXPECT_TRUE(x == x_one) << threads << " threads, solve " << solve;
        EXPECT_TRUE(v == v_one) << threads << " threads, solve " << solve;
      }
    }
  }
}

// MPRGP on the orthant and APGD on discs, on a program of 16 020 variables: their loops and
// sums go on threads, the sums in fixed chunks, so 1, 2, 3 and 4 threads give the same iterates
// and answer, bit for bit.
TEST(Mprgp, ThreadsGiveTheSameBits) {
  std::mt19937 rng(5);
  const test::NetworkProgram program = test::gridProgram(66, rng);
  ASSERT_GT(program.variables(), kParallelItems);  // on threads, in more than one chunk
  for (bool discs : {false, true}) {
    SeparableSet set;
    for (int j = 0; j < program.variables(); j += discs ? 2 : 1)
      set.add(discs ? BlockSet::Ball : BlockSet::NonNegative, discs ? 2 : 1, kDiscRadius);
    std::vector<double> x_one;
    VectorX v_one;
    const std::vector<int> counts = test::threadCounts();
    for (int threads : counts) {
      MprgpSettings settings;
      settings.tolerance = 1e-6;
      settings.max_iterations = 5000;
      settings.threads = threads;
      MprgpWorkspace ws;
      std::vector<double> x(program.variables(), 0.0);
      VectorX v = VectorX::Zero(program.velocities());
      const MprgpStats stats = discs ? solveApgd(program, set, settings, x, v, ws)
                                     : solveMprgp(program, set, settings, x, v, ws);
      ASSERT_TRUE(stats.converged) << threads << " threads, residual " << stats.residual;
      if (threads == counts[0]) {
        x_one = x;
        v_one = v;
        std::printf("%s: %d iterations on %d threads\n", discs ? "APGD, discs" : "MPRGP, orthant",
                    stats.iterations, threads);
        continue;
      }
      EXPECT_TRUE(x == x_one) << threads << " threads";
      EXPECT_TRUE(v == v_one) << threads << " threads";
    }
  }
}

// Programs large enough to be ordered by dissection (sparse_cholesky.cpp), of graphs that
// METIS's separator meets at its edges: no entry off the diagonal (contacts with the ground
// alone), many small components, a long thin strip, a grid with loose contacts beside it.
// Each is solved by Newton steps alone, to the tolerance, with the same bits on 1 and 2
// threads.
TEST(ProjectedNewton, LargeProgramsOfAnyGraphShape) {
  struct Shape {
    const char* name;
    std::function<test::NetworkProgram(std::mt19937&)> build;
  };
  const std::vector<Shape> shapes = {
      {"ground contacts only",
       [](std::mt19937& rng) {
         test::NetworkProgram program(6000);
         for (int k = 0; k < 6000; ++k) program.addContact(k, -1, k % 2 == 0, rng);
         return program;
       }},
      {"120 small grids",
       [](std::mt19937& rng) {
         test::NetworkProgram program(120 * 36);
         for (int g = 0; g < 120; ++g) program.addGrid(36 * g, 6, 6, rng);
         return program;
       }},
      {"a 3 x 2000 strip",
       [](std::mt19937& rng) {
         test::NetworkProgram program(3 * 2000);
         program.addGrid(0, 2000, 3, rng);
         for (int i = 0; i < 2000; i += 50) program.addContact(3 * i, -1, true, rng);
         return program;
       }},
      {"a grid and loose contacts",
       [](std::mt19937& rng) {
         test::NetworkProgram program(50 * 50 + 2000);
         program.addGrid(0, 50, 50, rng);
         for (int k = 0; k < 2000; ++k) program.addContact(2500 + k, -1, true, rng);
         return program;
       }},
  };
  for (const Shape& shape : shapes) {
    std::mt19937 rng(11);
    const test::NetworkProgram program = shape.build(rng);
    ASSERT_GE(program.variables(), 4096) << shape.name << ": too small to be dissected";
    SeparableSet set;
    for (int j = 0; j < program.variables(); ++j) set.add(BlockSet::NonNegative, 1);
    std::vector<double> x_one;
    for (int threads : {1, 2}) {
      MprgpSettings settings;
      settings.tolerance = 1e-10;
      settings.threads = threads;
      ProjectedNewtonWorkspace ws;
      MprgpWorkspace fallback;
      std::vector<double> x(program.variables(), 0.0);
      VectorX v = VectorX::Zero(program.velocities());
      const MprgpStats stats = solveProjectedNewton(program, set, settings, x, v, ws, fallback);
      ASSERT_TRUE(stats.converged) << shape.name << ", residual " << stats.residual;
      EXPECT_EQ(stats.newton_steps, stats.iterations) << shape.name << ": handed to MPRGP";
      if (threads == 1)
        x_one = x;
      else
        EXPECT_TRUE(x == x_one) << shape.name;
    }
  }
}

// The factorization alone, on a matrix dissected into two sides and a separator: a 2D grid's
// 5-point matrix of 5 000 rows, random weights. The sides' rows list-scheduled onto threads and
// the separator by its Schur complement solve it to rounding, with the bits of one thread on
// 2 and 3 threads, on a refactorization with new values, and inside a caller's parallel region
// (whose nested team of one thread runs the rows in order).
TEST(SparseCholesky, ScheduledRowsAndSchurSeparatorKeepTheBitsOfOneThread) {
  const int side = 70, n = side * side;
  std::vector<int> begin(1, 0), row;
  for (int j = 0; j < n; ++j) {
    row.push_back(j);
    if ((j + 1) % side != 0) row.push_back(j + 1);
    if (j + side < n) row.push_back(j + side);
    begin.push_back(static_cast<int>(row.size()));
  }
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> weight(0.1, 1.0);
  auto values = [&] {
    // off the diagonal -w, on it the sum of its row's weights and a little: positive definite
    std::vector<double> value(row.size(), 0.0), diagonal(n, 1e-3);
    for (int j = 0; j < n; ++j)
      for (int e = begin[j] + 1; e < begin[j + 1]; ++e) {
        value[e] = -weight(rng);
        diagonal[j] -= value[e];
        diagonal[row[e]] -= value[e];
      }
    for (int j = 0; j < n; ++j) value[begin[j]] = diagonal[j];
    return value;
  };
  auto residual = [&](const std::vector<double>& value, const std::vector<double>& rhs,
                      const std::vector<double>& x) {
    std::vector<double> r = rhs;
    for (int j = 0; j < n; ++j)
      for (int e = begin[j]; e < begin[j + 1]; ++e) {
        r[row[e]] -= value[e] * x[j];
        if (row[e] != j) r[j] -= value[e] * x[row[e]];
      }
    double worst = 0.0;
    for (double ri : r) worst = std::max(worst, std::abs(ri));
    return worst;
  };
  std::vector<double> rhs(n);
  for (double& b : rhs) b = weight(rng) - 0.5;
  for (int round = 0; round < 2; ++round) {
    const std::vector<double> value = values();
    std::vector<double> x_one;
    for (int threads : {1, 2, 3, -2}) {  // -2: two threads asked for inside a parallel region
      SparseCholesky cholesky;
      std::vector<double> x(n, 0.0);
      bool factorized = false;
      if (threads > 0) {
        ASSERT_TRUE(cholesky.analyze(n, begin, row, threads));
        // a first factorization of other values, so that the one compared is a refactorization
        if (round == 1) {
          ASSERT_TRUE(cholesky.factorize(values()));
        }
        factorized = cholesky.factorize(value);
        cholesky.solve(rhs, x);
        if (threads > 1) {
          EXPECT_EQ(cholesky.threads(), threads) << "the split is not taken";
        }
      } else {
#pragma omp parallel num_threads(2)
        {
#pragma omp single
          {
            if (cholesky.analyze(n, begin, row, -threads)) {
              factorized = cholesky.factorize(value);
              cholesky.solve(rhs, x);
            }
          }
        }
      }
      ASSERT_TRUE(factorized) << threads << " threads";
      EXPECT_LT(residual(value, rhs, x), 1e-10) << threads << " threads";
      if (threads == 1)
        x_one = x;
      else
        EXPECT_TRUE(x == x_one) << threads << " threads, round " << round;
    }
  }
}

// Two solves at once on two threads of the caller's (two simulations run by Python threads),
// each ordered by dissection: each gives the bits of the same solve alone. METIS draws from a
// process-wide generator, which the two would otherwise share.
TEST(ProjectedNewton, TwoSolvesAtOnceGiveTheBitsOfOne) {
  std::mt19937 rng(5);
  const test::NetworkProgram program = test::gridProgram(90, rng);
  SeparableSet set;
  for (int j = 0; j < program.variables(); ++j) set.add(BlockSet::NonNegative, 1);
  auto solve = [&](std::vector<double>& x) {
    MprgpSettings settings;
    settings.tolerance = 1e-10;
    settings.threads = 1;
    ProjectedNewtonWorkspace ws;
    MprgpWorkspace fallback;
    // four orderings each, as a run's steps would bring (one per new pattern)
    for (int round = 0; round < 4; ++round) {
      x.assign(program.variables(), 0.0);
      VectorX v = VectorX::Zero(program.velocities());
      solveProjectedNewton(program, set, settings, x, v, ws, fallback);
      ws = ProjectedNewtonWorkspace();  // a fresh analysis each round
    }
  };
  std::vector<double> alone;
  solve(alone);
  std::vector<double> first, second;
  std::thread one([&] { solve(first); }), two([&] { solve(second); });
  one.join();
  two.join();
  EXPECT_TRUE(first == alone);
  EXPECT_TRUE(second == alone);
}

// Stage 5a on a settled 150-disk pile and on a 120-sphere powder heap: the velocities are
// unique; MPRGP reaches NLGS's to the tolerance in fewer iterations than NLGS's sweeps.
TEST(ConvexStages, NormalStageMatchesNlgs) {
  for (bool spheres : {false, true}) {
    const test::SettledProblem settled =
        spheres ? test::settledPowderHeap(NormalLaw::Vel)
                : test::settledPile(150, 1500, NormalLaw::Vel, Scheme::CatchingUp);
    const ContactProblem& p = settled.step.problem;
    ASSERT_GT(p.size(), 100);
    SolverWorkspace ws;
    ws.prepare(p.size(), settled.scene.model.nv);
    SolverSettings solver;
    solver.max_iterations = 200000;
    solver.tolerance = 1e-10;
    std::vector<VectorX> velocities;
    std::vector<int> iterations;
    for (StageSolver method : {StageSolver::Nlgs, StageSolver::Mprgp, StageSolver::Newton}) {
      solver.solver = method;
      std::vector<double> lambda_N(p.size(), 0.0);
      VectorX v = settled.step.v_free;
      const SolverStats stats = solveNormalStage(p, solver, lambda_N, v, ws);
      EXPECT_EQ(stats.status, SolverStatus::Converged) << enumName(method);
      for (double lambda : lambda_N) EXPECT_GE(lambda, 0.0);
      velocities.push_back(v);
      iterations.push_back(stats.iterations);
    }
    std::printf(
        "stage 5a, %d contacts (%s), cold, to 1e-10: NLGS %d sweeps, MPRGP %d iterations, "
        "projected Newton %d steps\n",
        p.size(), spheres ? "spheres" : "disks", iterations[0], iterations[1], iterations[2]);
    const double scale = (velocities[0] - settled.step.v_free).norm();
    EXPECT_LT((velocities[1] - velocities[0]).norm(), 1e-6 * scale);
    EXPECT_LT((velocities[2] - velocities[0]).norm(), 1e-6 * scale);
    EXPECT_LT(iterations[1], iterations[0]);
    EXPECT_LT(iterations[2], iterations[1]);
  }
}

// Both stages by MPRGP / APGD on a wide, shallow settled pile of 2 000 disks and of 1 500
// spheres, with the products taken by the coloured sweeps' chunks (parallel_rows lowered to
// reach them): 1, 2, 3 and 4 threads give the same bits. The rows' own order (parallel_rows out
// of reach) sums the velocities in another order: other bits, the same answer to the tolerance.
TEST(ConvexStages, ColouredProductsGiveTheSameBitsOnAnyThreadCount) {
  for (bool planar : {true, false}) {
    GranularBoxParameters box;
    box.count = planar ? 2000 : 1500;
    box.planar = planar;
    box.width = planar ? 0.4 : 0.08;  // a few rows deep: settled in a few hundred steps
    SchemeSettings scheme;
    scheme.scheme = Scheme::CatchingUp;
    scheme.h = 4e-4;
    scheme.normal_stage.solver = StageSolver::Mprgp;
    scheme.friction_stage.solver = StageSolver::Mprgp;
    // the settling only has to close a network: a loose tolerance makes it cheap under the
    // sanitizers; the solves compared below run to 1e-7
    scheme.normal_stage.tolerance = 1e-3;
    scheme.friction_stage.tolerance = 1e-3;
    const test::SettledProblem pile =
        test::settledProblem(granularBox(box), scheme, 150, NormalLaw::Vel);
    const ContactProblem& p = pile.step.problem;
    const int n = p.size();
    std::printf("%s: %d contacts\n", planar ? "disks" : "spheres", n);
    ASSERT_GT(n, 8 * kColourChunk);  // blocks enough for several in one colour
    ASSERT_EQ(static_cast<int>(p.row_components.size()), n);
    SolverSettings settings;
    settings.solver = StageSolver::Mprgp;
    settings.max_iterations = 5000;
    settings.tolerance = 1e-7;
    settings.parallel_rows = 16;
    const FrictionStageOptions options;
    auto solve = [&](int threads) {
      SolverWorkspace ws;
      ws.prepare(n, pile.scene.model.nv, static_cast<int>(pile.scene.model.components.size()));
      settings.threads = threads;
      std::vector<double> lambda_N(n, 0.0), delta(n, 0.0);
      std::vector<Vector2> lambda_T(n, Vector2::Zero());
      VectorX v = pile.step.v_free;
      const SolverStats normal = solveNormalStage(p, settings, lambda_N, v, ws);
      const SolverStats friction =
          solveFrictionStage(p, settings, options, lambda_N, delta, lambda_T, v, ws);
      EXPECT_EQ(normal.status, SolverStatus::Converged) << threads << " threads";
      EXPECT_EQ(friction.status, SolverStatus::Converged) << threads << " threads";
      return v;
    };
    const std::vector<int> counts = test::threadCounts();
    const VectorX reference = solve(counts[0]);
    for (size_t k = 1; k < counts.size(); ++k)
      EXPECT_TRUE(solve(counts[k]) == reference) << (planar ? "disks, " : "spheres, ") << counts[k];
    settings.parallel_rows = 1 << 30;
    const VectorX in_row_order = solve(2);
    const double scale = (reference - pile.step.v_free).norm();
    EXPECT_LT((in_row_order - reference).norm(), 1e-5 * scale) << (planar ? "disks" : "spheres");
    EXPECT_FALSE(in_row_order == reference);
  }
}

// Stage 5b (every tangent mode on the disks; GLOBAL with rolling resistance on the powder
// heap): the convex solver converges to 1e-10, and its answer is checked by NLGS. On the disks,
// NLGS's own residual at that answer, after one sweep from it, is below 1e-8 and the sweep
// moves the velocities by under 1e-5 of the change (measured 1.2e-6 to 1.6e-6). Cold, NLGS stops at
// its 1e-7 where GLOBAL's redundant held rows leave it up to 3 % off the velocity change (its
// stopping test measures the sweep, not the distance to the solution); on the spheres its
// velocities agree to 1e-4 of the change.
TEST(ConvexStages, FrictionStageMatchesNlgs) {
  for (bool spheres : {false, true}) {
    const test::SettledProblem settled =
        spheres ? test::settledPowderHeap(NormalLaw::Vel)
                : test::settledPile(150, 1500, NormalLaw::Vel, Scheme::CatchingUp);
    const ContactProblem& p = settled.step.problem;
    SolverWorkspace ws;
    ws.prepare(p.size(), settled.scene.model.nv);
    SolverSettings convex;
    convex.max_iterations = 20000;
    convex.tolerance = 1e-10;
    convex.solver = StageSolver::Mprgp;
    std::vector<double> lambda_N(p.size(), 0.0);
    VectorX v1 = settled.step.v_free;
    ASSERT_EQ(solveNormalStage(p, convex, lambda_N, v1, ws).status, SolverStatus::Converged);
    // the active-set Newton solver: the 2D intervals, and the 3D discs in their frames
    for (TangentMode mode : {TangentMode::Global, TangentMode::Local, TangentMode::None})
      for (StageSolver method : {StageSolver::Mprgp, StageSolver::Newton}) {
        // spheres: GLOBAL only; the disks cover the other modes
        if (spheres && mode != TangentMode::Global) continue;
        convex.solver = method;
        FrictionStageOptions options;
        options.tangents = mode;
        std::vector<double> delta(p.size(), 0.0);
        std::vector<Vector2> lambda_T(p.size(), Vector2::Zero());
        std::vector<Vector2> R(p.size(), Vector2::Zero());
        std::vector<Vector2>* rolling = p.rolling ? &R : nullptr;
        VectorX v = v1;
        const SolverStats stats =
            solveFrictionStage(p, convex, options, lambda_N, delta, lambda_T, v, ws, rolling);
        EXPECT_EQ(stats.status, SolverStatus::Converged) << enumName(mode);
        // the Newton steps converge by themselves, well before the hand-over to MPRGP
        // (measured: 15 steps for GLOBAL's redundant held rows, 4 for LOCAL and NONE)
        if (method == StageSolver::Newton) {
          EXPECT_LT(stats.iterations, 50) << enumName(mode);
        }
        for (int c = 0; c < p.size(); ++c) {
          EXPECT_LE(lambda_T[c].norm(), p.friction[c] * lambda_N[c] * (1.0 + 1e-12) + 1e-30);
        }
        const double change = (v - v1).norm();
        ASSERT_GT(change, 0.0);
        SolverSettings nlgs;
        nlgs.tolerance = 1e-7;
        nlgs.max_iterations = spheres ? 20000 : 1;
        std::vector<double> delta_nlgs = delta;
        std::vector<Vector2> lambda_T_nlgs = lambda_T, R_nlgs = R;
        if (spheres) {
          std::fill(delta_nlgs.begin(), delta_nlgs.end(), 0.0);
          std::fill(lambda_T_nlgs.begin(), lambda_T_nlgs.end(), Vector2::Zero());
          std::fill(R_nlgs.begin(), R_nlgs.end(), Vector2::Zero());
        }
        VectorX v_nlgs = v1;
        const SolverStats check =
            solveFrictionStage(p, nlgs, options, lambda_N, delta_nlgs, lambda_T_nlgs, v_nlgs, ws,
                               p.rolling ? &R_nlgs : nullptr);
        std::printf(
            "stage 5b %s, %d contacts (%s): %s %d iterations to 1e-10; NLGS %s %.2e, "
            "velocities %.2e apart (relative to the change)\n",
            enumName(mode), p.size(), spheres ? "spheres" : "disks", enumName(method),
            stats.iterations, spheres ? "cold, residual" : "one sweep from it, residual",
            check.residual, (v_nlgs - v).norm() / change);
        if (spheres) {
          EXPECT_LT((v_nlgs - v).norm(), 1e-4 * change);
          continue;
        }
        EXPECT_LT(check.residual, 1e-8) << enumName(mode);
        EXPECT_LT((v_nlgs - v).norm(), 1e-5 * change) << enumName(mode);
      }
  }
}

// A row that moves nothing (W_NN = 0: a degenerate normal) carries nothing and leaves every
// number finite, where a scale of 1 / sqrt(W_NN) would turn it into NaN.
TEST(ConvexStages, ARowThatMovesNothingCarriesNothing) {
  ContactProblem p;
  p.dimension = 2;
  p.contact = {0};
  p.begin = {0, 2};
  p.minv_begin = {0, 2};
  p.dof = {0, 1};
  p.minv_dof = {0, 1};
  p.h = {Vector3(0.0, 1.0, 0.0), Vector3(0.0, 0.0, 0.0)};
  p.minv_h = p.h;
  Matrix3 W = Matrix3::Zero();
  W(1, 1) = 1.0;
  p.delassus = {W};
  p.delassus_inverse = {Matrix3::Zero()};
  p.normal_compliance_inverse = {0.0};
  p.known = {Vector3::Zero()};
  p.gap = {0.0};
  p.friction = {0.5};
  p.restitution = {0.0};
  p.velocity_start = {Vector3(-1.0, 0.0, 0.0)};
  p.normal_bias = {-0.1};  // asks for a push the row cannot give
  SolverWorkspace ws;
  ws.prepare(1, 2);
  SolverSettings solver;
  solver.solver = StageSolver::Mprgp;
  std::vector<double> lambda_N = {1.0};
  VectorX v = Eigen::Vector2d(1.0, -1.0);
  const SolverStats normal = solveNormalStage(p, solver, lambda_N, v, ws);
  EXPECT_NE(normal.status, SolverStatus::Failed);
  EXPECT_EQ(lambda_N[0], 0.0);
  std::vector<double> delta = {0.0};
  std::vector<Vector2> lambda_T = {Vector2::Zero()};
  const std::vector<double> pushed = {1.0};  // a threshold from a normal impulse of 1
  const SolverStats friction = solveFrictionStage(p, solver, FrictionStageOptions{}, pushed, delta,
                                                  lambda_T, v, ws, nullptr);
  EXPECT_NE(friction.status, SolverStatus::Failed);
  EXPECT_TRUE(v.allFinite());
  EXPECT_TRUE(std::isfinite(delta[0]) && lambda_T[0].allFinite());
}

}  // namespace
}  // namespace sweep
