// What detection needs before its broadphase: the geometries' poses at the detection time, and
// the margins within which pairs are kept (contact/detection.hpp).
#include <algorithm>
#include <cmath>
#include <limits>

#include "contact/detection.hpp"
#include "framework/parallel.hpp"

namespace sweep {

void updateGeometryPoses(const Model& model, const Data& data, const ContactModel& cmodel, double t,
                         ContactData& cdata) {
  const int n = cmodel.size();
  forEachIndex(n, data.threads, [&](int i) {
    const Geometry& g = cmodel.geometries[i];
    switch (g.body.kind) {
      case BodyRef::Kind::World:
        cdata.geometry_pose[i] = g.placement;
        break;
      case BodyRef::Kind::Dynamic:
        cdata.geometry_pose[i] = data.world_pose[g.body.index] * g.placement;
        break;
      case BodyRef::Kind::Driven:
        cdata.geometry_pose[i] = model.driven_bodies[g.body.index].pose(t) * g.placement;
        break;
    }
  });
}

double fastestShapeSpeed(const Model& model, const Data& data, const ContactModel& cmodel,
                         double t) {
  // std::max(fastest, x) leaves a NaN x out, in any order: chunks on threads change nothing
  return reduceInChunks(
      cmodel.size(), data.threads, 0.0,
      [&](long i, double& fastest) {
        const Geometry& g = cmodel.geometries[i];
        Vector6 twist = Vector6::Zero();
        if (g.body.kind == BodyRef::Kind::Dynamic) twist = data.velocity[g.body.index];
        if (g.body.kind == BodyRef::Kind::Driven)
          twist = model.driven_bodies[g.body.index].twist(t);
        // |v_origin| + |w| * (distance of any shape point from the body origin)
        const double reach =
            isUnbounded(g.shape) ? 0.0 : g.placement.translation.norm() + boundingRadius(g.shape);
        fastest = std::max(fastest, twist.tail<3>().norm() + twist.head<3>().norm() * reach);
      },
      [](double& fastest, double part) { fastest = std::max(fastest, part); });
}

double ballClosingSpeed(const Model& model, const Data& data, const ContactModel& cmodel,
                        double t) {
  // A ball's surface moves with its centre whatever it spins, so the centres' velocities
  // bound every gap between two balls; any common velocity u drops out of their differences.
  auto centreVelocity = [&](int i) -> Vector3 {
    const Geometry& g = cmodel.geometries[i];
    const BodyRef& body = cmodel.traits[i].body_ref;
    if (body.kind == BodyRef::Kind::Dynamic) {
      const Vector6& twist = data.velocity[body.index];  // body coordinates
      const Vector3 local =
          twist.tail<3>() + twist.head<3>().cross(Vector3(g.placement.translation));
      return data.world_pose[body.index].rotation * local;
    }
    if (body.kind == BodyRef::Kind::Driven) {
      const DrivenBody& driven = model.driven_bodies[body.index];
      return driven.pointVelocity(driven.pose(t).apply(g.placement.translation), t);
    }
    return Vector3::Zero();
  };
  // min and max leave NaN entries out, in any order: chunks on threads change nothing
  struct Bounds {
    Vector3 low, high;
    double fastest;
  };
  const Vector3 none = Vector3::Constant(std::numeric_limits<double>::infinity());
  const auto [low, high, fastest] = reduceInChunks(
      cmodel.size(), data.threads, Bounds{none, -none, 0.0},
      [&](long i, Bounds& part) {
        if (!(cmodel.traits[i].ball_radius > 0.0)) return;
        const Vector3 c = centreVelocity(static_cast<int>(i));
        part.low = part.low.cwiseMin(c);
        part.high = part.high.cwiseMax(c);
        part.fastest = std::max(part.fastest, c.norm());
      },
      [](Bounds& total, const Bounds& part) {
        total.low = total.low.cwiseMin(part.low);
        total.high = total.high.cwiseMax(part.high);
        total.fastest = std::max(total.fastest, part.fastest);
      });
  if (!(low.x() <= high.x())) return 0.0;  // no balls
  const double spread = 0.5 * (high - low).norm();
  // a non-finite spread compares false and leaves the absolute bound, as fastestShapeSpeed
  // leaves non-finite speeds out
  return spread < fastest ? spread : fastest;
}

double detectionMargin(const Model& model, const Data& data, const ContactModel& cmodel, double h,
                       double t) {
  // an adhesive law's range reaches open candidates (IQS, POS): they must be detected
  return std::max(cmodel.settings.speed_factor * h * fastestShapeSpeed(model, data, cmodel, t) +
                      cmodel.margin_floor,
                  cmodel.adhesion_reach);
}

DetectionMargins detectionMargins(const Model& model, const Data& data, const ContactModel& cmodel,
                                  double h, double t) {
  const double others = detectionMargin(model, data, cmodel, h, t);
  if (cmodel.settings.margin_rule == MarginRule::Absolute) return DetectionMargins::uniform(others);
  const double balls =
      std::max(cmodel.settings.speed_factor * h * ballClosingSpeed(model, data, cmodel, t) +
                   cmodel.margin_floor,
               cmodel.adhesion_reach);
  return {std::min(balls, others), others};
}

}  // namespace sweep
