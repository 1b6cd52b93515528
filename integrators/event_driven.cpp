#include "integrators/event_driven.hpp"

#include <cmath>
#include <stdexcept>

#include "framework/crba.hpp"
#include "framework/error.hpp"

namespace sweep {

EventDrivenReference::EventDrivenReference(const Model& model,
                                           std::vector<UnilateralConstraint> constraints,
                                           EventDrivenSettings settings)
    : model_(model),
      constraints_(std::move(constraints)),
      settings_(settings),
      smooth_(model, settings.smooth),
      data_(model) {
  for (const UnilateralConstraint& c : constraints_) {
    if (!c.gap || !c.normal) throw InputError("event-driven reference: constraint without gap");
    if (!(c.restitution >= 0.0 && c.restitution <= 1.0))
      throw InputError("event-driven reference: restitution must be in [0, 1], got " +
                       formatValue(c.restitution));
  }
  smooth_.setEvents(static_cast<int>(constraints_.size()),
                    [this](double, const VectorX& q, const VectorX&, VectorX& g) {
                      for (std::size_t i = 0; i < constraints_.size(); ++i)
                        g[static_cast<Eigen::Index>(i)] = constraints_[i].gap(q);
                    });
}

void EventDrivenReference::reset(double t0, const VectorX& q0, const VectorX& v0) {
  impacts_.clear();
  accumulated_ = false;
  smooth_.reset(t0, q0, v0);
}

void EventDrivenReference::advanceTo(double t_out) {
  while (!accumulated_ && smooth_.time() < t_out) {
    const bool at_root = smooth_.advanceTo(t_out);
    for (std::size_t i = 0; i < constraints_.size(); ++i) {
      const double gap = constraints_[i].gap(smooth_.q());
      if (gap < -1e-9)
        throw std::runtime_error("event-driven reference: constraint " + std::to_string(i) +
                                 " crossed without a root at t = " + formatValue(smooth_.time()) +
                                 " (gap " + formatValue(gap) + ")");
    }
    if (!at_root) return;
    const VectorX q = smooth_.q();
    VectorX v = smooth_.v();
    crba(model_, data_, q);
    factorizeMassMatrix(model_, data_);
    for (std::size_t i = 0; i < constraints_.size(); ++i) {
      if (smooth_.events()[i] == 0) continue;
      const UnilateralConstraint& c = constraints_[i];
      const VectorX W = c.normal(q);
      VectorX minv_W;
      applyMassInverse(model_, data_, W, minv_W);
      const double before = W.dot(v);
      if (before >= 0.0) continue;  // grazing: nothing to reverse
      const double P = -(1.0 + c.restitution) * before / W.dot(minv_W);
      v += P * minv_W;
      const double after = W.dot(v);
      impacts_.push_back({smooth_.time(), static_cast<int>(i), before, after});
      if (after < settings_.accumulation_speed) accumulated_ = true;
    }
    smooth_.reset(smooth_.time(), q, v);
  }
}

}  // namespace sweep
