// No heap allocation inside the solvers: every operator new of the process is counted while
// a solve runs. Stronger than Eigen's malloc check, which sees Eigen's own allocations only.
#include <gtest/gtest.h>

#include <array>

#include <atomic>
#include <cstdlib>
#include <new>

#include "integrators/nlgs.hpp"
#include "integrators/projected_newton.hpp"
#include "integrators/stage_solvers.hpp"
#include "integrators/time_stepper.hpp"
#include "models/granular.hpp"
#include "solver_fixtures.hpp"

namespace {
std::atomic<bool> counting{false};
std::atomic<long> allocations{0};
}  // namespace

void* operator new(std::size_t size) {
  if (counting) ++allocations;
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}

namespace sweep {
namespace {

struct Counted {
  Counted() {
    allocations = 0;
    counting = true;
  }
  ~Counted() { counting = false; }
};

// A settled pile; then one step's problem is built by hand and each solver runs on it with
// the counter armed.
TEST(NoAllocation, InsideEverySolver) {
  for (bool planar : {true, false}) {
    const test::SettledProblem pile =
        test::settledPile(120, 400, NormalLaw::Pos, Scheme::MoreauJean, planar);
    const Scene& scene = pile.scene;
    const Model& model = scene.model;
    const test::StepProblem& step = pile.step;
    const ContactProblem& problem = step.problem;
    const VectorX& v_free = step.v_free;
    const int n = problem.size();
    ASSERT_GT(n, 50);
    SolverWorkspace ws;
    ws.prepare(n, model.nv);
    SolverSettings nlgs;
    nlgs.max_iterations = 50;
    nlgs.shuffle = true;

    std::vector<Vector3> P(n, Vector3::Zero());
    VectorX v_a = v_free;
    {
      Counted counted;
      solveCoulombNlgs(problem, nlgs, P, v_a, ws);
    }
    EXPECT_EQ(allocations, 0) << (planar ? "2D" : "3D") << " Moreau-Jean";
    // the coloured sweeps on two threads, with the NNCG momentum: the team of threads is made
    // on the first parallel region, so a first solve runs before the counted one
    SolverSettings coloured = nlgs;
    coloured.shuffle = false;
    coloured.parallel_rows = 16;
    coloured.threads = 2;
    coloured.acceleration = NlgsAcceleration::Nncg;
    for (int round = 0; round < 2; ++round) {
      std::vector<Vector3> P_coloured(n, Vector3::Zero());
      VectorX v_coloured = v_free;
      Counted counted;
      solveCoulombNlgs(problem, coloured, P_coloured, v_coloured, ws);
      counting = false;
      if (round == 1) {
        EXPECT_EQ(allocations, 0) << (planar ? "2D" : "3D") << " coloured sweeps";
      }
    }

    std::vector<double> lambda_N(n, 0.0);
    std::vector<Vector2> lambda_T(n, Vector2::Zero());
    VectorX v_b = v_free;
    {
      Counted counted;
      solveNormalStage(problem, nlgs, lambda_N, v_b, ws);
    }
    EXPECT_EQ(allocations, 0) << (planar ? "2D" : "3D") << " normal stage";
    for (FrictionThreshold threshold : {FrictionThreshold::Physical, FrictionThreshold::Metric}) {
      FrictionStageOptions options;
      options.threshold = threshold;
      // POS: the projection on the closed normals runs, by conjugate gradients, whose
      // workspace is sized on its first call (as the convex stages'): a second solve counts
      for (int round = 0; round < 2; ++round) {
        std::vector<double> delta(n, 0.0);
        std::vector<Vector2> lambda_T_round = lambda_T;
        VectorX v_c = v_b;
        Counted counted;
        solveFrictionStage(problem, nlgs, options, lambda_N, delta, lambda_T_round, v_c, ws);
        counting = false;
        if (round == 1) {
          EXPECT_EQ(allocations, 0) << (planar ? "2D" : "3D") << " friction stage";
        }
      }
    }
  }
}

// The convex stage solvers size their workspaces on a solve's first call (and the Newton
// solver orders and analyses a new pattern there); solving the same problem again, as a step
// whose contacts did not change does, allocates nothing.
TEST(NoAllocation, ConvexStagesOnTheirSecondSolve) {
  for (bool planar : {true, false}) {
    const test::SettledProblem pile =
        test::settledPile(120, 400, NormalLaw::Pos, Scheme::CatchingUp, planar);
    const ContactProblem& problem = pile.step.problem;
    const int n = problem.size();
    ASSERT_GT(n, 50);
    // the last: MPRGP / APGD with their products by the coloured chunks, on two threads
    for (int configuration = 0; configuration < 4; ++configuration) {
      const StageSolver solver =
          std::array{StageSolver::Mprgp, StageSolver::Newton, StageSolver::InteriorPoint,
                     StageSolver::Mprgp}[configuration];
      SolverWorkspace ws;
      ws.prepare(n, pile.scene.model.nv);
      SolverSettings settings;
      settings.solver = solver;
      settings.max_iterations = 200;
      if (configuration == 3) {
        settings.parallel_rows = 16;
        settings.threads = 2;
      }
      FrictionStageOptions options;
      for (int round = 0; round < 2; ++round) {
        std::vector<double> lambda_N(n, 0.0), delta(n, 0.0);
        std::vector<Vector2> lambda_T(n, Vector2::Zero());
        VectorX v = pile.step.v_free;
        {
          Counted counted;
          solveNormalStage(problem, settings, lambda_N, v, ws);
          solveFrictionStage(problem, settings, options, lambda_N, delta, lambda_T, v, ws);
        }
        if (round == 1) {
          EXPECT_EQ(allocations, 0) << (planar ? "2D " : "3D ") << enumName(solver) << " stages"
                                    << (configuration == 3 ? ", coloured on two threads" : "");
        }
      }
    }
  }
}

// The Newton solver's threaded path (a 16 020-row program, its factorization split over 2
// threads, its loops and chunked sums on threads): a second solve of the same pattern
// allocates nothing either.
TEST(NoAllocation, ThreadedNewtonSolveOnItsSecondCall) {
  std::mt19937 rng(5);
  const test::NetworkProgram program = test::gridProgram(90, rng);
  SeparableSet set;
  for (int j = 0; j < program.variables(); ++j) set.add(BlockSet::NonNegative, 1);
  MprgpSettings settings;
  settings.threads = 2;
  ProjectedNewtonWorkspace ws;
  MprgpWorkspace fallback;
  for (int round = 0; round < 2; ++round) {
    std::vector<double> x(program.variables(), 0.0);
    VectorX v = VectorX::Zero(program.velocities());
    MprgpStats stats;
    {
      Counted counted;
      stats = solveProjectedNewton(program, set, settings, x, v, ws, fallback);
    }
    ASSERT_TRUE(stats.converged);
    ASSERT_EQ(stats.newton_steps, stats.iterations);
    ASSERT_EQ(ws.factorThreads(), 2) << "the factorization must be split for this test";
    if (round == 1) {
      EXPECT_EQ(allocations, 0) << "threaded Newton solve";
    }
  }
}

// MPRGP on the orthant and APGD on discs on two threads (a 8 580-variable program: its loops
// and chunked sums on threads): a second solve allocates nothing.
TEST(NoAllocation, ThreadedMprgpAndApgdOnTheirSecondCall) {
  std::mt19937 rng(5);
  const test::NetworkProgram program = test::gridProgram(66, rng);
  for (bool discs : {false, true}) {
    SeparableSet set;
    for (int j = 0; j < program.variables(); j += discs ? 2 : 1)
      set.add(discs ? BlockSet::Ball : BlockSet::NonNegative, discs ? 2 : 1, 1.0);
    MprgpSettings settings;
    settings.threads = 2;
    settings.max_iterations = 100;
    MprgpWorkspace ws;
    for (int round = 0; round < 2; ++round) {
      std::vector<double> x(program.variables(), 0.0);
      VectorX v = VectorX::Zero(program.velocities());
      {
        Counted counted;
        if (discs)
          solveApgd(program, set, settings, x, v, ws);
        else
          solveMprgp(program, set, settings, x, v, ws);
      }
      if (round == 1) {
        EXPECT_EQ(allocations, 0) << (discs ? "APGD" : "MPRGP") << " on two threads";
      }
    }
  }
}

}  // namespace
}  // namespace sweep
