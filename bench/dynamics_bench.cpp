// CRBA + RNEA cost on a 6-dof arm and a 30-dof branched tree (issue #2 target: 6-dof CRBA +
// RNEA together under 1 us). Run: ./build/bench/dynamics_bench
#include <benchmark/benchmark.h>

#include "framework/crba.hpp"
#include "framework/dynamics.hpp"
#include "framework/rnea.hpp"
#include "framework/urdf_import.hpp"
#include "models/kinematic_trees.hpp"

namespace {

// Times `work(model, data, q, v)` at a fixed, generic state.
template <class Work>
void run(benchmark::State& state, const sweep::Model& model, Work work) {
  sweep::Data data(model);
  const sweep::VectorX q = sweep::VectorX::LinSpaced(model.nq, -0.7, 0.9);
  const sweep::VectorX v = sweep::VectorX::LinSpaced(model.nv, 0.4, -0.6);
  for (auto _ : state) {
    work(model, data, q, v);
    benchmark::DoNotOptimize(data.mass_blocks[0].data());
    benchmark::DoNotOptimize(data.tau.data());
  }
}

void crbaAndRnea(const sweep::Model& m, sweep::Data& d, const sweep::VectorX& q,
                 const sweep::VectorX& v) {
  sweep::crba(m, d, q);
  sweep::biasForces(m, d, q, v);
}
void crbaOnly(const sweep::Model& m, sweep::Data& d, const sweep::VectorX& q,
              const sweep::VectorX&) {
  sweep::crba(m, d, q);
}
void rneaOnly(const sweep::Model& m, sweep::Data& d, const sweep::VectorX& q,
              const sweep::VectorX& v) {
  sweep::biasForces(m, d, q, v);
}

const sweep::Model& arm() {
  static const sweep::Model m = sweep::serialArm6();
  return m;
}
const sweep::Model& tree30() {
  static const sweep::Model m = sweep::branchedTree(30);
  return m;
}

void BM_Arm6_CrbaRnea(benchmark::State& s) {
  run(s, arm(), crbaAndRnea);
}
void BM_Arm6_AllTerms(benchmark::State& s) {
  run(s, arm(), sweep::computeAllTerms);
}
void BM_Tree30_AllTerms(benchmark::State& s) {
  run(s, tree30(), sweep::computeAllTerms);
}
void BM_Arm6_Crba(benchmark::State& s) {
  run(s, arm(), crbaOnly);
}
void BM_Arm6_Rnea(benchmark::State& s) {
  run(s, arm(), rneaOnly);
}
void BM_Tree30_CrbaRnea(benchmark::State& s) {
  run(s, tree30(), crbaAndRnea);
}
void BM_Tree30_Crba(benchmark::State& s) {
  run(s, tree30(), crbaOnly);
}
void BM_Tree30_Rnea(benchmark::State& s) {
  run(s, tree30(), rneaOnly);
}

// examples/archetypes/arm6.urdf, the model bench/python_overhead.py calls from Python
const sweep::Model& armUrdf() {
  static const sweep::Model m = sweep::loadUrdf(SWEEP_SOURCE_DIR "/examples/archetypes/arm6.urdf");
  return m;
}
void BM_Arm6Urdf_BiasForces(benchmark::State& s) {
  run(s, armUrdf(), rneaOnly);
}
void BM_Arm6Urdf_MassMatrix(benchmark::State& s) {
  run(s, armUrdf(),
      [](const sweep::Model& m, sweep::Data& d, const sweep::VectorX& q, const sweep::VectorX&) {
        sweep::crba(m, d, q);
        const sweep::MatrixX M = sweep::denseMassMatrix(m, d);
        benchmark::DoNotOptimize(M.data());
      });
}
void BM_Arm6Urdf_ForwardDynamics(benchmark::State& s) {
  run(s, armUrdf(),
      [](const sweep::Model& m, sweep::Data& d, const sweep::VectorX& q, const sweep::VectorX& v) {
        sweep::forwardDynamics(m, d, q, v, v);
        benchmark::DoNotOptimize(d.ddq.data());
      });
}
BENCHMARK(BM_Arm6Urdf_BiasForces);
BENCHMARK(BM_Arm6Urdf_MassMatrix);
BENCHMARK(BM_Arm6Urdf_ForwardDynamics);

}  // namespace

BENCHMARK(BM_Arm6_CrbaRnea);
BENCHMARK(BM_Arm6_AllTerms);
BENCHMARK(BM_Arm6_Crba);
BENCHMARK(BM_Arm6_Rnea);
BENCHMARK(BM_Tree30_CrbaRnea);
BENCHMARK(BM_Tree30_AllTerms);
BENCHMARK(BM_Tree30_Crba);
BENCHMARK(BM_Tree30_Rnea);
BENCHMARK_MAIN();
