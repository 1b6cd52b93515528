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
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "apps/sweep/scene_file.hpp"
#include "integrators/time_stepper.hpp"

namespace {

struct Fill {
  long n = 0, entries = 0;
  double factor_entries = 0.0, flops = 0.0;
  double simplicial_seconds = 0.0, supernodal_seconds = 0.0;
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
  Fill fill{n, entries, common.lnz, common.fl, 0.0, 0.0};
  cholmod_free_factor(&factor, &common);
  // the numeric factorizations' times, on values that make the matrix positive definite
  cholmod_sparse* pattern = a;
  a = cholmod_allocate_sparse(n, n, entries, 1, 1, -1, CHOLMOD_REAL, &common);
  std::copy(p, p + n + 1, static_cast<int*>(a->p));
  std::copy(i, i + entries, static_cast<int*>(a->i));
  cholmod_free_sparse(&pattern, &common);
  double* x = static_cast<double*>(a->x);
  for (int j = 0; j < n; ++j)
    for (int e = static_cast<int*>(a->p)[j]; e < static_cast<int*>(a->p)[j + 1]; ++e)
      x[e] = static_cast<int*>(a->i)[e] == j ? 1e4 : -0.5;
  for (int kind : {CHOLMOD_SIMPLICIAL, CHOLMOD_SUPERNODAL}) {
    common.supernodal = kind;
    common.final_ll = kind == CHOLMOD_SUPERNODAL;
    cholmod_factor* numeric = cholmod_analyze(a, &common);
    const auto start = std::chrono::steady_clock::now();
    cholmod_factorize(a, numeric, &common);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    (kind == CHOLMOD_SIMPLICIAL ? fill.simplicial_seconds : fill.supernodal_seconds) = seconds;
    if (common.status != CHOLMOD_OK) std::fprintf(stderr, "factorization failed\n");
    cholmod_free_factor(&numeric, &common);
  }
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
  std::printf(
      "%-28s n %8ld  entries %10ld  factor entries %12.0f  flops %10.3e  simplicial %.4f s  "
      "supernodal %.4f s\n",
      form, fill.n, fill.entries, fill.factor_entries, fill.flops, fill.simplicial_seconds,
      fill.supernodal_seconds);
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
  const std::vector<sweep::Contact>& found = stepper.data().contact_data.contacts;
  const int contacts = static_cast<int>(found.size()), nv = model.nv;
  // the components each contact moves (all of a body's tree: a superset of its Jacobian's
  // velocities where a tree has branches, exact for free bodies), and the contacts that move
  // each component
  std::vector<std::vector<int>> moves(contacts), moved_by(model.components.size());
  for (int c = 0; c < contacts; ++c) {
    for (const sweep::BodyRef& body : {found[c].body_a, found[c].body_b})
      if (body.hasDofs()) moves[c].push_back(model.bodies[body.index].component);
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
    for (int k : moves[c])
      for (int l : moves[c]) {
        const sweep::Component &first = model.components[k], &second = model.components[l];
        for (int i = 0; i < first.nv; ++i)
          for (int j = 0; j < second.nv; ++j) addPair(lower, first.v_index + i, second.v_index + j);
      }
  tidy(lower);
  print("body space", analyze(nv, lower));
  return 0;
}
