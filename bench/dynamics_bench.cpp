// CRBA + RNEA cost on a 6-dof arm and a 30-dof branched tree (issue #2 target: 6-dof CRBA +
// RNEA together under 1 us). Run: ./build/bench/dynamics_bench
#include <benchmark/benchmark.h>

#include "framework/crba.hpp"
#include "framework/rnea.hpp"
#include "models/kinematic_trees.hpp"

namespace {

void runCrbaRnea(benchmark::State& state, const sweep::Model& model) {
  sweep::Data data(model);
  const sweep::VectorX q = sweep::VectorX::LinSpaced(model.nq, -0.7, 0.9);
  const sweep::VectorX v = sweep::VectorX::LinSpaced(model.nv, 0.4, -0.6);
  for (auto _ : state) {
    sweep::crba(model, data, q);
    sweep::biasForces(model, data, q, v);
    benchmark::DoNotOptimize(data.mass_blocks[0].data());
    benchmark::DoNotOptimize(data.tau.data());
  }
}

void runAllTerms(benchmark::State& state, const sweep::Model& model) {
  sweep::Data data(model);
  const sweep::VectorX q = sweep::VectorX::LinSpaced(model.nq, -0.7, 0.9);
  const sweep::VectorX v = sweep::VectorX::LinSpaced(model.nv, 0.4, -0.6);
  for (auto _ : state) {
    sweep::computeAllTerms(model, data, q, v);
    benchmark::DoNotOptimize(data.mass_blocks[0].data());
    benchmark::DoNotOptimize(data.tau.data());
  }
}

void runCrba(benchmark::State& state, const sweep::Model& model) {
  sweep::Data data(model);
  const sweep::VectorX q = sweep::VectorX::LinSpaced(model.nq, -0.7, 0.9);
  for (auto _ : state) {
    sweep::crba(model, data, q);
    benchmark::DoNotOptimize(data.mass_blocks[0].data());
  }
}

void runRnea(benchmark::State& state, const sweep::Model& model) {
  sweep::Data data(model);
  const sweep::VectorX q = sweep::VectorX::LinSpaced(model.nq, -0.7, 0.9);
  const sweep::VectorX v = sweep::VectorX::LinSpaced(model.nv, 0.4, -0.6);
  for (auto _ : state) {
    sweep::biasForces(model, data, q, v);
    benchmark::DoNotOptimize(data.tau.data());
  }
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
  runCrbaRnea(s, arm());
}
void BM_Arm6_AllTerms(benchmark::State& s) {
  runAllTerms(s, arm());
}
void BM_Tree30_AllTerms(benchmark::State& s) {
  runAllTerms(s, tree30());
}
void BM_Arm6_Crba(benchmark::State& s) {
  runCrba(s, arm());
}
void BM_Arm6_Rnea(benchmark::State& s) {
  runRnea(s, arm());
}
void BM_Tree30_CrbaRnea(benchmark::State& s) {
  runCrbaRnea(s, tree30());
}
void BM_Tree30_Crba(benchmark::State& s) {
  runCrba(s, tree30());
}
void BM_Tree30_Rnea(benchmark::State& s) {
  runRnea(s, tree30());
}

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
