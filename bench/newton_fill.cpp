// The sparse Cholesky factor that a Newton method on a contact problem would factorize, in
// the two forms it can take (docs/benchmarks.md, "Newton matrices: contact space or body
// space"):
//
//   contact space:  A + D,          A = H^T M^-1 H  (one row per contact variable)
//   body space:     M + H D^-1 H^T                  (one row per velocity)
//
// D is diagonal (or 2 x 2 per disc), so each form's pattern is fixed by the contacts alone:
// two contact variables couple when their contacts move a common component of the model (M
// is block diagonal by component), two velocities when a contact or a component holds both.
// For each form: its order, the entries of its lower triangle, and those of its Cholesky
// factor and the factorization's flops under CHOLMOD's own ordering choice (AMD or METIS).
// Usage: newton_fill SCENE.yaml STEPS [KEY=VALUE ...]: the scene's state after STEPS steps of
// its own scheme, the overrides as sweep run --set takes them.
#include <cholmod.h>

#include <algorithm>
#include <cstdio>
#include <string>
#include <vector>

#include "apps/sweep/scene_file.hpp"
#include "integrators/time_stepper.hpp"

namespace {

struct Fill {
  long n = 0, entries = 0;
  double factor_entries = 0.0, flops = 0.0;
};

// the lower triangle's pattern (columns of sorted, unique rows, the diagonal included)
Fill analyze(int n, const std::vector<std::vector<int>>& lower) {
  cholmod_common common;
  cholmod_start(&common);
  common.supernodal = CHOLMOD_SUPERNODAL;
  long entries = 0;
  for (const std::vector<int>& column : lower) entries += static_cast<long>(column.size());
  cholmod_sparse* a = cholmod_allocate_sparse(n, n, entries, 1, 1, -1, CHOLMOD_PATTERN, &common);
  int* p = static_cast<int*>(a->p);
  int* i = static_cast<int*>(a->i);
  p[0] = 0;
  for (int j = 0; j < n; ++j) {
    std::copy(lower[j].begin(), lower[j].end(), i + p[j]);
    p[j + 1] = p[j] + static_cast<int>(lower[j].size());
  }
  cholmod_factor* factor = cholmod_analyze(a, &common);
  Fill fill{n, entries, common.lnz, common.fl};
  cholmod_free_factor(&factor, &common);
  cholmod_free_sparse(&a, &common);
  cholmod_finish(&common);
  return fill;
}

void addPair(std::vector<std::vector<int>>& lower, int i, int j) {
  lower[std::min(i, j)].push_back(std::max(i, j));
}

void tidy(std::vector<std::vector<int>>& lower) {
  for (std::size_t j = 0; j < lower.size(); ++j) {
    lower[j].push_back(static_cast<int>(j));
    std::sort(lower[j].begin(), lower[j].end());
    lower[j].erase(std::unique(lower[j].begin(), lower[j].end()), lower[j].end());
  }
}

void print(const char* form, const Fill& fill) {
  std::printf("%-28s n %8ld  entries %10ld  factor entries %12.0f  flops %10.3e\n", form, fill.n,
              fill.entries, fill.factor_entries, fill.flops);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: newton_fill SCENE.yaml STEPS [KEY=VALUE ...]\n");
    return 2;
  }
  const std::vector<std::string> overrides(argv + 3, argv + argc);
  sweep::SceneFile file = sweep::loadSceneFile(argv[1], overrides);
  const sweep::Scene scene = sweep::buildSceneFile(file);
  sweep::TimeStepper stepper(scene.model, scene.cmodel, file.run.scheme, scene.forces);
  stepper.reset(0.0, scene.q0, scene.v0);
  for (int k = std::stoi(argv[2]); k > 0; --k) stepper.step();
  stepper.step();  // the contacts of this step's detection are the ones analysed

  const sweep::Model& model = scene.model;
  const sweep::ContactJacobian& jacobian = stepper.data().contact_data.jacobian;
  const int contacts = jacobian.size(), nv = model.nv;
  // the component of each velocity
  std::vector<int> component_of(nv, -1);
  for (std::size_t k = 0; k < model.components.size(); ++k)
    for (int i = 0; i < model.components[k].nv; ++i)
      component_of[model.components[k].v_index + i] = static_cast<int>(k);
  // the components each contact moves, and the contacts that move each component
  std::vector<std::vector<int>> moves(contacts), moved_by(model.components.size());
  for (int c = 0; c < contacts; ++c) {
    for (int e = jacobian.begin[c]; e < jacobian.begin[c + 1]; ++e)
      moves[c].push_back(component_of[jacobian.dof[e]]);
    std::sort(moves[c].begin(), moves[c].end());
    moves[c].erase(std::unique(moves[c].begin(), moves[c].end()), moves[c].end());
    for (int k : moves[c]) moved_by[k].push_back(c);
  }
  std::printf("%d contacts, %d velocities, %zu components\n", contacts, nv,
              model.components.size());

  // contact space, `per` variables per contact (1: the normal stage; 2: a 3D friction stage)
  for (int per : {1, 2}) {
    std::vector<std::vector<int>> lower(per * contacts);
    for (const std::vector<int>& group : moved_by)
      for (int c : group)
        for (int e : group)
          if (e <= c)
            for (int a = 0; a < per; ++a)
              for (int b = 0; b < per; ++b) addPair(lower, per * c + a, per * e + b);
    tidy(lower);
    print(per == 1 ? "contact space, 1 per contact" : "contact space, 2 per contact",
          analyze(per * contacts, lower));
  }
  // body space: M's blocks and H D^-1 H^T
  std::vector<std::vector<int>> lower(nv);
  for (const sweep::Component& component : model.components)
    for (int i = 0; i < component.nv; ++i)
      for (int j = 0; j <= i; ++j) addPair(lower, component.v_index + i, component.v_index + j);
  for (int c = 0; c < contacts; ++c)
    for (int e = jacobian.begin[c]; e < jacobian.begin[c + 1]; ++e)
      for (int f = jacobian.begin[c]; f < jacobian.begin[c + 1]; ++f)
        addPair(lower, jacobian.dof[e], jacobian.dof[f]);
  tidy(lower);
  print("body space", analyze(nv, lower));
  return 0;
}
