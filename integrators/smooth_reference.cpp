#include "integrators/smooth_reference.hpp"

#include <cvode/cvode.h>
#include <nvector/nvector_serial.h>
#include <sunnonlinsol/sunnonlinsol_fixedpoint.h>

#include <stdexcept>
#include <string>

#include "framework/configuration.hpp"
#include "framework/dynamics.hpp"
#include "framework/error.hpp"

namespace sweep {

void SmoothReferenceSettings::validate() const {
  if (!(relative_tolerance > 0.0))
    throw InputError("smooth reference: relative_tolerance must be > 0, got " +
                     formatValue(relative_tolerance));
  if (!(absolute_tolerance > 0.0))
    throw InputError("smooth reference: absolute_tolerance must be > 0, got " +
                     formatValue(absolute_tolerance));
  if (max_steps <= 0) throw InputError("smooth reference: max_steps must be > 0");
  if (max_order < 1 || max_order > 12)
    throw InputError("smooth reference: max_order must be in [1, 12]");
}

struct SmoothReferenceIntegrator::Cvode {
  SUNContext context = nullptr;
  N_Vector y = nullptr;
  SUNNonlinearSolver corrector = nullptr;
  void* memory = nullptr;
  bool initialized = false;

  ~Cvode() {
    if (memory) CVodeFree(&memory);
    if (corrector) SUNNonlinSolFree(corrector);
    if (y) N_VDestroy(y);
    if (context) SUNContext_Free(&context);
  }

  static int rhs(sunrealtype t, N_Vector y, N_Vector ydot, void* user) {
    static_cast<SmoothReferenceIntegrator*>(user)->derivative(t, N_VGetArrayPointer(y),
                                                              N_VGetArrayPointer(ydot));
    return 0;
  }
  static int roots(sunrealtype t, N_Vector y, sunrealtype* g, void* user) {
    static_cast<SmoothReferenceIntegrator*>(user)->eventValues(t, N_VGetArrayPointer(y), g);
    return 0;
  }
};

namespace {
void check(int flag, const char* call) {
  if (flag < 0)
    throw std::runtime_error(std::string("CVODE ") + call + " failed with flag " +
                             std::to_string(flag));
}
}  // namespace

SmoothReferenceIntegrator::SmoothReferenceIntegrator(const Model& model,
                                                     SmoothReferenceSettings settings,
                                                     ForceFunction force)
    : model_(model),
      data_(model),
      settings_(settings),
      force_(std::move(force)),
      q_(model.neutralConfiguration()),
      v_(VectorX::Zero(model.nv)),
      tau_(VectorX::Zero(model.nv)),
      qdot_(VectorX::Zero(model.nq)),
      cvode_(std::make_unique<Cvode>()) {
  settings_.validate();
  check(SUNContext_Create(nullptr, &cvode_->context), "SUNContext_Create");
  cvode_->y = N_VNew_Serial(model.nq + model.nv, cvode_->context);
  cvode_->memory = CVodeCreate(CV_ADAMS, cvode_->context);
  if (!cvode_->y || !cvode_->memory) throw std::runtime_error("CVODE: allocation failed");
  cvode_->corrector = SUNNonlinSol_FixedPoint(cvode_->y, 0, cvode_->context);
  if (!cvode_->corrector) throw std::runtime_error("CVODE: allocation failed");
}

SmoothReferenceIntegrator::~SmoothReferenceIntegrator() = default;

long SmoothReferenceIntegrator::steps() const {
  long n = 0;
  if (cvode_->initialized) CVodeGetNumSteps(cvode_->memory, &n);
  return n;
}

void SmoothReferenceIntegrator::derivative(double t, const double* y, double* ydot) {
  q_ = Eigen::Map<const VectorX>(y, model_.nq);
  v_ = Eigen::Map<const VectorX>(y + model_.nq, model_.nv);
  tau_.setZero();
  if (force_) force_(t, q_, v_, tau_);
  configurationRate(model_, q_, v_, qdot_);
  forwardDynamics(model_, data_, q_, v_, tau_);
  Eigen::Map<VectorX>(ydot, model_.nq) = qdot_;
  Eigen::Map<VectorX>(ydot + model_.nq, model_.nv) = data_.ddq;
}

void SmoothReferenceIntegrator::setEvents(int count, EventFunction events) {
  if (cvode_->initialized) throw std::logic_error("smooth reference: setEvents() after reset()");
  if (count < 0 || (count > 0 && !events))
    throw InputError("smooth reference: event count must be >= 0, with a function");
  event_count_ = count;
  events_ = std::move(events);
  roots_.assign(count, 0);
}

void SmoothReferenceIntegrator::eventValues(double t, const double* y, double* g) {
  q_ = Eigen::Map<const VectorX>(y, model_.nq);
  v_ = Eigen::Map<const VectorX>(y + model_.nq, model_.nv);
  event_values_.resize(event_count_);
  events_(t, q_, v_, event_values_);
  Eigen::Map<VectorX>(g, event_count_) = event_values_;
}

void SmoothReferenceIntegrator::reset(double t0, const VectorX& q0, const VectorX& v0) {
  if (q0.size() != model_.nq || v0.size() != model_.nv)
    throw InputError("smooth reference: state has the wrong size");
  if (!q0.allFinite() || !v0.allFinite())
    throw InputError("smooth reference: initial state has non-finite entries");
  t_ = t0;
  q_ = q0;
  v_ = v0;
  double* y = N_VGetArrayPointer(cvode_->y);
  Eigen::Map<VectorX>(y, model_.nq) = q0;
  Eigen::Map<VectorX>(y + model_.nq, model_.nv) = v0;
  void* mem = cvode_->memory;
  if (!cvode_->initialized) {
    check(CVodeInit(mem, &Cvode::rhs, t0, cvode_->y), "CVodeInit");
    check(CVodeSetNonlinearSolver(mem, cvode_->corrector), "CVodeSetNonlinearSolver");
    if (event_count_ > 0) {
      check(CVodeRootInit(mem, event_count_, &Cvode::roots), "CVodeRootInit");
      std::vector<int> downward(event_count_, -1);
      check(CVodeSetRootDirection(mem, downward.data()), "CVodeSetRootDirection");
    }
    cvode_->initialized = true;
  } else {
    check(CVodeReInit(mem, t0, cvode_->y), "CVodeReInit");
  }
  check(CVodeSetUserData(mem, this), "CVodeSetUserData");
  check(CVodeSStolerances(mem, settings_.relative_tolerance, settings_.absolute_tolerance),
        "CVodeSStolerances");
  check(CVodeSetMaxNumSteps(mem, settings_.max_steps), "CVodeSetMaxNumSteps");
  check(CVodeSetMaxOrd(mem, settings_.max_order), "CVodeSetMaxOrd");
}

bool SmoothReferenceIntegrator::advanceTo(double t_out) {
  if (!cvode_->initialized) throw std::logic_error("smooth reference: reset() before advanceTo()");
  double t_reached = t_;
  const int flag = CVode(cvode_->memory, t_out, cvode_->y, &t_reached, CV_NORMAL);
  check(flag, "CVode");
  const bool at_root = flag == CV_ROOT_RETURN;
  if (at_root) check(CVodeGetRootInfo(cvode_->memory, roots_.data()), "CVodeGetRootInfo");
  const double* y = N_VGetArrayPointer(cvode_->y);
  t_ = t_reached;
  q_ = Eigen::Map<const VectorX>(y, model_.nq);
  v_ = Eigen::Map<const VectorX>(y + model_.nq, model_.nv);
  normalizeConfiguration(model_, q_);
  return at_root;
}

}  // namespace sweep
