#pragma once
// Shared by the solver tests: the contact problem of one step, built by hand from a stepper's
// state with the library's stage functions, so that a solver can be called on its own.
#include <gtest/gtest.h>

#include <cstdlib>
#include <random>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "framework/dynamics.hpp"
#include "framework/kinematics.hpp"
#include "integrators/mprgp.hpp"
#include "integrators/time_stepper.hpp"
#include "models/granular.hpp"
#include "models/powder_bed.hpp"
#include "models/scene_spec.hpp"

namespace sweep::test {

struct StepProblem {
  ContactProblem problem;
  VectorX v_free;
};

// The problem of the step that would start at state (q, v) (detection at that state: the
// tests need a realistic problem, not the exact midpoint one). body_form: whether the
// assembly may write rows over free particles in body form (ContactProblem::pack_body_form);
// compact_spheres: rows over free spheres in compact form (ContactProblem::compact_spheres).
inline StepProblem problemAt(const Scene& scene, const VectorX& q, const VectorX& v, double h,
                             NormalLaw law, bool body_form = true, bool compact_spheres = false) {
  const Model& model = scene.model;
  Data data(model);
  ContactData cdata(model, scene.cmodel);
  forwardKinematics(model, data, q, v);
  detectContacts(model, data, scene.cmodel, cdata, 0.0,
                 detectionMargin(model, data, scene.cmodel, h, 0.0));
  StepProblem out;
  out.problem.pack_body_form = body_form;
  out.problem.compact_spheres = compact_spheres;
  out.v_free = v + h * forwardDynamics(model, data, q, v, VectorX::Zero(model.nv));
  assembleContactJacobian(model, data, scene.cmodel, cdata, 0.0);
  ContactProblemWorkspace workspace(model);
  assembleContactProblem(model, data, scene.cmodel, cdata, 0.0, law, 0.5 * h, q, v, out.problem,
                         workspace);
  return out;
}
inline StepProblem problemAt(const Scene& scene, const TimeStepper& stepper, NormalLaw law) {
  return problemAt(scene, stepper.q(), stepper.v(), stepper.settings().h, law);
}

// A scene stepped `steps` times from its initial state with `settings` (its applied forces
// included), and the problem of the step after, built with `law`.
struct SettledProblem {
  Scene scene;
  StepProblem step;
  VectorX q, v;  // the state the step starts from
  double h = 0.0;
};
inline SettledProblem settledProblem(Scene scene, const SchemeSettings& settings, int steps,
                                     NormalLaw law) {
  SettledProblem out{std::move(scene), {}, {}, {}, settings.h};
  TimeStepper stepper(out.scene.model, out.scene.cmodel, settings, out.scene.forces);
  stepper.reset(0.0, out.scene.q0, out.scene.v0);
  for (int k = 0; k < steps; ++k) stepper.step();
  out.q = stepper.q();
  out.v = stepper.v();
  out.step = problemAt(out.scene, stepper, law);
  return out;
}

// A granular box of `count` grains settled by `scheme` at h = 2e-4.
inline SettledProblem settledPile(int count, int steps, NormalLaw law,
                                  Scheme scheme = Scheme::MoreauJean, bool planar = true) {
  GranularBoxParameters parameters;
  parameters.count = count;
  parameters.planar = planar;
  SchemeSettings settings;
  settings.scheme = scheme;
  settings.h = 2e-4;
  // a fixed state for the solver tests, whatever the default stage solver
  settings.normal_stage.solver = StageSolver::Mprgp;
  settings.friction_stage.solver = StageSolver::Mprgp;
  return settledProblem(granularBox(parameters), settings, steps, law);
}

// A small powder heap (120 spheres, friction, rolling resistance) settled for 800 steps of
// 1e-5 s with VEL.
inline SettledProblem settledPowderHeap(NormalLaw law) {
  PowderBedParameters parameters;
  parameters.count = 120;
  parameters.length = 1.5e-3;
  parameters.travel = 0.5e-3;
  parameters.heap_length = 0.4e-3;
  parameters.settle_time = 0.01;
  SchemeSettings settings;
  settings.h = 1e-5;
  settings.normal_law = NormalLaw::Vel;
  return settledProblem(buildScene(powderBed(parameters)), settings, 800, law);
}

// The thread counts a same-bits-for-every-count test compares, the first one its reference:
// SWEEP_TEST_THREAD_COUNTS ("2,4") where set, else 1, 2, 3 and 4. The sanitizer runs take two
// counts (scripts/sanitize.sh, tsan.sh): an instrumented solve costs 10 to 30 plain ones.
inline std::vector<int> threadCounts() {
  std::vector<int> counts;
  if (const char* listed = std::getenv("SWEEP_TEST_THREAD_COUNTS")) {
    std::stringstream in(listed);
    std::string item;
    while (std::getline(in, item, ',')) counts.push_back(std::stoi(item));
  }
  if (counts.size() < 2) counts = {1, 2, 3, 4};
  return counts;
}

// Test-name suffix of a scheme parameter.
inline std::string schemeTestName(const ::testing::TestParamInfo<Scheme>& info) {
  return info.param == Scheme::MoreauJean ? "MoreauJean" : "CatchingUp";
}

// Test-name suffix of a tangent-mode parameter, and every tangent mode of scheme B's stage 5b.
inline std::string tangentModeTestName(const ::testing::TestParamInfo<TangentMode>& info) {
  return enumName(info.param);
}
inline auto allTangentModes() {
  return ::testing::Values(TangentMode::Global, TangentMode::Local, TangentMode::None);
}

// A sparse program shaped like a 2D contact network: the velocities are those of `nodes`
// nodes (two each), the variables contacts (>= 0), each between two nodes or a node and the
// ground: column j of B the contact's normal at its ends, weighted by a random inverse mass.
class NetworkProgram final : public QpOperator {
 public:
  explicit NetworkProgram(int nodes) : velocities_(2 * nodes) {}
  // a contact between nodes a and b (b < 0: the ground), its normal along x (or y) tilted
  void addContact(int a, int b, bool along_x, std::mt19937& rng) {
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    const double tilt = 0.2 * uniform(rng);
    const double nx = along_x ? 1.0 : tilt, ny = along_x ? tilt : 1.0;
    std::vector<std::pair<int, double>>& column = column_.emplace_back();
    for (int end = 0; end < 2; ++end) {
      const int k = end == 0 ? a : b;
      const double sign = end == 0 ? -1.0 : 1.0, w = 1.0 + 0.5 * uniform(rng);
      if (k < 0) continue;
      column.push_back({2 * k, sign * nx * w});
      column.push_back({2 * k + 1, sign * ny * w});
    }
    b_.push_back(uniform(rng));  // pressed or pushed apart
  }
  // contacts between the neighbours of a rows x columns grid of nodes from `first` on
  void addGrid(int first, int rows, int columns, std::mt19937& rng) {
    auto node = [&](int i, int j) { return first + i * columns + j; };
    for (int i = 0; i < rows; ++i)
      for (int j = 0; j < columns; ++j)
        for (int dir = 0; dir < 2; ++dir) {
          const int ni = i + (dir == 0), nj = j + (dir == 1);
          if (ni < rows && nj < columns) addContact(node(i, j), node(ni, nj), dir == 0, rng);
        }
  }
  int variables() const { return static_cast<int>(column_.size()); }
  int velocities() const { return velocities_; }
  void toVelocity(const std::vector<double>& x, VectorX& z) const override {
    z = VectorX::Zero(velocities_);
    for (std::size_t j = 0; j < column_.size(); ++j)
      for (const auto& [k, a] : column_[j]) z[k] += a * x[j];
  }
  void toGradient(const VectorX& v, bool affine, std::vector<double>& y) const override {
    for (std::size_t j = 0; j < column_.size(); ++j) {
      double sum = affine ? -b_[j] : 0.0;
      for (const auto& [k, a] : column_[j]) sum += a * v[k];
      y[j] = sum;
    }
  }
  bool columns(SparseColumns& J, SparseColumns& K) const override {
    for (const auto& entries : column_) {
      for (const auto& [k, a] : entries) {
        J.push(k, a);
        K.push(k, a);
      }
      J.endColumn();
      K.endColumn();
    }
    return true;
  }

 private:
  int velocities_;
  std::vector<std::vector<std::pair<int, double>>> column_;
  std::vector<double> b_;
};

// The network of a side x side grid: large enough that the factorization is split over threads.
inline NetworkProgram gridProgram(int side, std::mt19937& rng) {
  NetworkProgram program(side * side);
  program.addGrid(0, side, side, rng);
  return program;
}

}  // namespace sweep::test
