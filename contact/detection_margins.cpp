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

namespace {
// a ball's centre velocity in world coordinates (its surface moves with it whatever it spins)
Vector3 ballCentreVelocity(const Model& model, const Data& data, const ContactModel& cmodel, int i,
                           double t) {
  const Geometry& g = cmodel.geometries[i];
  const BodyRef& body = cmodel.traits[i].body_ref;
  if (body.kind == BodyRef::Kind::Dynamic) {
    const Vector6& twist = data.velocity[body.index];  // body coordinates
    const Vector3 local = twist.tail<3>() + twist.head<3>().cross(Vector3(g.placement.translation));
    return data.world_pose[body.index].rotation * local;
  }
  if (body.kind == BodyRef::Kind::Driven) {
    const DrivenBody& driven = model.driven_bodies[body.index];
    return driven.pointVelocity(driven.pose(t).apply(g.placement.translation), t);
  }
  return Vector3::Zero();
}
}  // namespace

void MarginSpeeds::combine(const MarginSpeeds& part) {
  // std::max and min leave NaN entries out, in any order
  fastest_shape = std::max(fastest_shape, part.fastest_shape);
  ball_low = ball_low.cwiseMin(part.ball_low);
  ball_high = ball_high.cwiseMax(part.ball_high);
  ball_fastest = std::max(ball_fastest, part.ball_fastest);
}

double MarginSpeeds::ballClosing() const {
  if (!(ball_low.x() <= ball_high.x())) return 0.0;  // no balls
  const double spread = 0.5 * (ball_high - ball_low).norm();
  // a non-finite spread compares false and leaves the absolute bound, as fastestShapeSpeed
  // leaves non-finite speeds out
  return spread < ball_fastest ? spread : ball_fastest;
}

MarginSpeeds marginSpeeds(const Model& model, const Data& data, const ContactModel& cmodel,
                          double t, const std::vector<char>* counted) {
  // Any common velocity u drops out of two balls' centre velocities' difference: the box of
  // the centre velocities bounds every gap between two balls (ballClosingSpeed). Chunks on
  // threads change nothing: every reduction is a max or a min.
  return reduceInChunks(
      cmodel.size(), data.threads, MarginSpeeds{},
      [&](long i, MarginSpeeds& part) {
        const Geometry& g = cmodel.geometries[i];
        if (counted != nullptr && g.body.kind == BodyRef::Kind::Dynamic &&
            !(*counted)[g.body.index])
          return;
        Vector6 twist = Vector6::Zero();
        if (g.body.kind == BodyRef::Kind::Dynamic) twist = data.velocity[g.body.index];
        if (g.body.kind == BodyRef::Kind::Driven)
          twist = model.driven_bodies[g.body.index].twist(t);
        // |v_origin| + |w| * (distance of any shape point from the body origin)
        const double reach =
            isUnbounded(g.shape) ? 0.0 : g.placement.translation.norm() + boundingRadius(g.shape);
        part.fastest_shape =
            std::max(part.fastest_shape, twist.tail<3>().norm() + twist.head<3>().norm() * reach);
        if (!(cmodel.traits[i].ball_radius > 0.0)) return;
        const Vector3 c = ballCentreVelocity(model, data, cmodel, static_cast<int>(i), t);
        part.ball_low = part.ball_low.cwiseMin(c);
        part.ball_high = part.ball_high.cwiseMax(c);
        part.ball_fastest = std::max(part.ball_fastest, c.norm());
      },
      [](MarginSpeeds& total, const MarginSpeeds& part) { total.combine(part); });
}

double fastestShapeSpeed(const Model& model, const Data& data, const ContactModel& cmodel,
                         double t) {
  return marginSpeeds(model, data, cmodel, t).fastest_shape;
}

double fastestDrivenShapeSpeed(const Model& model, const ContactModel& cmodel, double t) {
  double fastest = 0.0;
  for (const Geometry& g : cmodel.geometries) {
    if (g.body.kind != BodyRef::Kind::Driven) continue;
    const Vector6 twist = model.driven_bodies[g.body.index].twist(t);
    const double reach =
        isUnbounded(g.shape) ? 0.0 : g.placement.translation.norm() + boundingRadius(g.shape);
    fastest = std::max(fastest, twist.tail<3>().norm() + twist.head<3>().norm() * reach);
  }
  return fastest;
}

double ballClosingSpeed(const Model& model, const Data& data, const ContactModel& cmodel,
                        double t) {
  return marginSpeeds(model, data, cmodel, t).ballClosing();
}

double detectionMargin(const Model& model, const Data& data, const ContactModel& cmodel, double h,
                       double t) {
  return detectionMargins(model, data, cmodel, h, t).others;
}

DetectionMargins detectionMargins(const Model& model, const Data& data, const ContactModel& cmodel,
                                  double h, double t) {
  return detectionMargins(cmodel, h, marginSpeeds(model, data, cmodel, t));
}

DetectionMargins detectionMargins(const ContactModel& cmodel, double h,
                                  const MarginSpeeds& speeds) {
  // an adhesive law's range reaches open candidates (IQS, POS): they must be detected
  const double others =
      std::max(cmodel.settings.speed_factor * h * speeds.fastest_shape + cmodel.margin_floor,
               cmodel.adhesion_reach);
  if (cmodel.settings.margin_rule == MarginRule::Absolute) return DetectionMargins::uniform(others);
  const double balls =
      std::max(cmodel.settings.speed_factor * h * speeds.ballClosing() + cmodel.margin_floor,
               cmodel.adhesion_reach);
  return {std::min(balls, others), others};
}

}  // namespace sweep
