#pragma once
// Shared by the solver tests: the contact problem of one step, built by hand from a stepper's
// state with the library's stage functions, so that a solver can be called on its own.
#include <gtest/gtest.h>

#include "framework/dynamics.hpp"
#include "framework/kinematics.hpp"
#include "integrators/time_stepper.hpp"
#include "models/granular.hpp"

namespace sweep::test {

struct StepProblem {
  ContactProblem problem;
  VectorX v_free;
};

// The problem of the step that would start at the stepper's current state (detection at
// that state: the tests need a realistic problem, not the exact midpoint one).
inline StepProblem problemAt(const Scene& scene, const TimeStepper& stepper, NormalLaw law) {
  const Model& model = scene.model;
  const double h = stepper.settings().h;
  Data data(model);
  ContactData cdata(model, scene.cmodel);
  const VectorX q = stepper.q(), v = stepper.v();
  forwardKinematics(model, data, q, v);
  detectContacts(model, data, scene.cmodel, cdata, 0.0,
                 detectionMargin(model, data, scene.cmodel, h, 0.0));
  StepProblem out;
  out.v_free = v + h * forwardDynamics(model, data, q, v, VectorX::Zero(model.nv));
  assembleContactJacobian(model, data, scene.cmodel, cdata, 0.0);
  ContactProblemWorkspace workspace(model);
  assembleContactProblem(model, data, scene.cmodel, cdata, law, 0.5 * h, q, v, out.problem,
                         workspace);
  return out;
}

// Test-name suffix of a scheme parameter.
inline std::string schemeTestName(const ::testing::TestParamInfo<Scheme>& info) {
  return info.param == Scheme::MoreauJean ? "MoreauJean" : "CatchingUp";
}

}  // namespace sweep::test
