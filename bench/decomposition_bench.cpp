// What the domain decomposition (contact/domain_decomposition.hpp) costs and sends on a real
// scene: a saved state's grains, weighted by 1 + their contacts of one step, dealt to the ranks
// round-robin, balanced, then one ghost exchange with each grain's q and v as payload (the
// exchange a distributed step makes every step). Prints one line: ranks, grains, the most
// owned on one rank, the work imbalance, the ghosts, the bytes the ghost exchange sends (all
// ranks, and the most from one), and the balance's time.
// Usage: [mpiexec -n R] decomposition_bench SCENE.yaml STATE.csv [KEY=VALUE ...]
// (KEY=VALUE as `sweep run --set`; GHOST=x sets the ghost width, default 2.2 times the largest
// grain radius: a pair's reach, the largest diameter, plus a tenth of a radius of margin).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

#include "apps/sweep/run.hpp"
#include "apps/sweep/scene_file.hpp"
#include "contact/domain_decomposition.hpp"
#include "framework/error.hpp"
#include "integrators/time_stepper.hpp"

int main(int argc, char** argv) {
  sweep::MpiSession mpi(argc, argv);
  const sweep::RankGroup ranks = sweep::RankGroup::world();
  if (argc < 3) {
    if (ranks.rank() == 0)
      std::fprintf(stderr, "usage: decomposition_bench SCENE.yaml STATE.csv [KEY=VALUE ...]\n");
    return 2;
  }
  double ghost_width = -1.0;
  std::vector<std::string> overrides;
  for (int k = 3; k < argc; ++k) {
    const std::string arg = argv[k];
    if (arg.rfind("GHOST=", 0) == 0) {
      char* end = nullptr;
      ghost_width = std::strtod(arg.c_str() + 6, &end);
      if (end == arg.c_str() + 6 || *end != '\0' || !(ghost_width >= 0.0)) {
        if (ranks.rank() == 0)
          std::fprintf(stderr, "decomposition_bench: GHOST must be a width >= 0, got '%s'\n",
                       arg.c_str() + 6);
        return 2;
      }
    } else {
      overrides.push_back(arg);
    }
  }
  try {
    sweep::SceneFile file = sweep::loadSceneFile(argv[1], overrides);
    const sweep::Scene scene = sweep::buildSceneFile(file);
    const sweep::SavedState state = sweep::readSavedState(argv[2], scene, 1.0);
    sweep::TimeStepper stepper(scene.model, scene.cmodel, file.run.scheme, scene.forces);
    stepper.reset(state.t, state.q, state.v);
    stepper.step();
    const sweep::Model& model = scene.model;
    const int dimension = scene.cmodel.dimension;
    std::vector<std::int64_t> contacts(model.bodies.size(), 0);
    for (const sweep::Contact& c : stepper.data().contact_data.contacts)
      for (const sweep::BodyRef& body : {c.body_a, c.body_b})
        if (body.hasDofs()) ++contacts[body.index];
    // the grains: balls on free bodies, dealt round-robin
    sweep::ParticleSet owned;
    owned.payload_width = dimension == 3 ? 13 : 6;
    double largest = 0.0;
    sweep::Vector3 lower = sweep::Vector3::Constant(1e300), upper = -lower;
    long grains = 0;
    for (const auto& traits : scene.cmodel.traits) {
      if (traits.ball_radius <= 0.0 || traits.component < 0) continue;
      const sweep::Component& component = model.components[traits.component];
      if (component.nv != (dimension == 3 ? 6 : 3)) continue;
      largest = std::max(largest, traits.ball_radius);
      const sweep::VectorX& q = stepper.q();
      const sweep::Vector3 p(q[component.q_index], q[component.q_index + 1],
                             dimension == 3 ? q[component.q_index + 2] : 0.0);
      lower = lower.cwiseMin(p);
      upper = upper.cwiseMax(p);
      if (grains++ % ranks.size() != ranks.rank()) continue;
      owned.id.push_back(traits.body);
      owned.position.push_back(p);
      owned.work.push_back(1 + contacts[traits.body]);
      for (int j = 0; j < component.nq; ++j) owned.payload.push_back(q[component.q_index + j]);
      for (int j = 0; j < component.nv; ++j)
        owned.payload.push_back(stepper.v()[component.v_index + j]);
    }
    sweep::DecompositionSettings settings;
    settings.dimension = dimension;
    settings.lower = lower;
    settings.upper = upper + sweep::Vector3::Constant(1e-12);
    if (dimension == 2) settings.upper.z() = 1.0;
    const sweep::Periodicity& periodic = scene.cmodel.settings.periodic;
    if (periodic.enabled()) {
      settings.periodic[periodic.axis] = true;
      settings.lower[periodic.axis] = periodic.low;
      settings.upper[periodic.axis] = periodic.high;
    }
    settings.ghost_width = ghost_width >= 0.0 ? ghost_width : 2.2 * largest;
    sweep::DomainDecomposition decomposition(ranks, settings);
    std::vector<std::int64_t> barrier{0};
    ranks.sum(barrier);  // every rank here: the time is the balance's, not the wait for the others
    const auto start = std::chrono::steady_clock::now();
    decomposition.balance(owned);
    const double balance_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    sweep::ParticleSet ghosts;
    const sweep::ExchangeStats sent = decomposition.exchangeGhosts(owned, ghosts);
    const double imbalance = decomposition.imbalance(owned);
    std::vector<std::int64_t> sums{owned.size(), ghosts.size(), sent.bytes};
    ranks.sum(sums);
    std::vector<double> most{static_cast<double>(owned.size()), static_cast<double>(sent.bytes),
                             balance_seconds};
    ranks.max(most);
    if (ranks.rank() == 0)
      std::printf(
          "ranks %d  grains %lld  most owned %.0f  work imbalance %.3f  ghosts %lld  "
          "ghost bytes %lld (most from one rank %.0f)  balance %.3f s\n",
          ranks.size(), static_cast<long long>(sums[0]), most[0], imbalance,
          static_cast<long long>(sums[1]), static_cast<long long>(sums[2]), most[1], most[2]);
    return 0;
  } catch (const sweep::InputError& e) {
    ranks.abort((std::string("decomposition_bench: ") + e.what()).c_str(), 2);
  } catch (const std::exception& e) {
    ranks.abort((std::string("decomposition_bench: ") + e.what()).c_str(), 1);
  }
}
