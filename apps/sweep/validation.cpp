#include "apps/sweep/validation.hpp"

#include <cmath>
#include <stdexcept>

#include "framework/energy.hpp"
#include "framework/kinematics.hpp"

namespace sweep {

namespace {

std::vector<UnilateralConstraint> wallPendulumConstraints(const WallPendulumParameters& p) {
  const double l1 = p.l1, l2 = p.l2;
  UnilateralConstraint upper, lower;
  upper.gap = [l1](const VectorX& q) { return l1 * std::sin(q[0]); };
  upper.normal = [l1](const VectorX& q) {
    return VectorX(Eigen::Vector2d(l1 * std::cos(q[0]), 0));
  };
  upper.curvature = [l1](const VectorX& q, const VectorX& v) {
    return -l1 * std::sin(q[0]) * v[0] * v[0];
  };
  upper.restitution = p.e_upper;
  lower.gap = [l1, l2](const VectorX& q) {
    return l1 * std::sin(q[0]) + l2 * std::sin(q[0] + q[1]);
  };
  lower.normal = [l1, l2](const VectorX& q) {
    const double c2 = l2 * std::cos(q[0] + q[1]);
    return VectorX(Eigen::Vector2d(l1 * std::cos(q[0]) + c2, c2));
  };
  lower.curvature = [l1, l2](const VectorX& q, const VectorX& v) {
    const double w2 = v[0] + v[1];
    return -l1 * std::sin(q[0]) * v[0] * v[0] - l2 * std::sin(q[0] + q[1]) * w2 * w2;
  };
  lower.restitution = p.e_lower;
  return {upper, lower};
}

double totalEnergy(const Model& model, Data& data, const VectorX& q, const VectorX& v) {
  forwardKinematics(model, data, q, v);
  return kineticEnergy(model, data) + potentialEnergy(model, data);
}

// the validation runs solve to 1e-12, so that the error measured is the scheme's, not the
// solver's
SchemeSettings tightSettings(Scheme scheme, double h) {
  SchemeSettings settings;
  settings.scheme = scheme;
  settings.h = h;
  settings.coulomb.tolerance = settings.normal_stage.tolerance = settings.friction_stage.tolerance =
      1e-12;
  return settings;
}

// sample count of t_end / interval, checked to be a whole number
long wholeRatio(double a, double b, const char* what) {
  const double ratio = a / b;
  const long n = std::lround(ratio);
  if (n < 1 || std::abs(ratio - static_cast<double>(n)) > 1e-9 * ratio)
    throw std::invalid_argument(std::string(what) + " is not a whole multiple");
  return n;
}

// A run of `scheme` at step h, sampled every sample_interval: the RMS over the samples
// j = 1 .. samples of squared_error(q at sample j, j).
double sampledRms(const Scene& scene, Scheme scheme, double h, double sample_interval, long samples,
                  const std::function<double(const VectorX&, long)>& squared_error) {
  const long per_sample = wholeRatio(sample_interval, h, "sample_interval / h");
  TimeStepper stepper(scene.model, scene.cmodel, tightSettings(scheme, h), scene.forces);
  stepper.reset(0.0, scene.q0, scene.v0);
  double sum = 0.0;
  for (long j = 1; j <= samples; ++j) {
    for (long k = 0; k < per_sample; ++k) stepper.step();
    sum += squared_error(stepper.q(), j);
  }
  return std::sqrt(sum / static_cast<double>(samples));
}

}  // namespace

std::vector<ConvergencePoint> convergenceStudy(const std::vector<double>& steps,
                                               const std::function<double(double h)>& error) {
  std::vector<ConvergencePoint> points;
  for (double h : steps) {
    ConvergencePoint point{h, error(h), 0.0};
    if (!points.empty()) point.order = std::log2(points.back().error / point.error);
    points.push_back(point);
  }
  return points;
}

double fittedOrder(const std::vector<ConvergencePoint>& points) {
  double mx = 0.0, my = 0.0;
  for (const ConvergencePoint& p : points) {
    mx += std::log2(p.h);
    my += std::log2(p.error);
  }
  mx /= static_cast<double>(points.size());
  my /= static_cast<double>(points.size());
  double sxy = 0.0, sxx = 0.0;
  for (const ConvergencePoint& p : points) {
    sxy += (std::log2(p.h) - mx) * (std::log2(p.error) - my);
    sxx += (std::log2(p.h) - mx) * (std::log2(p.h) - mx);
  }
  return sxy / sxx;
}

std::vector<UnilateralConstraint> bouncingBallConstraints(
    const BouncingBallParameters& parameters) {
  UnilateralConstraint floor;
  const double radius = parameters.radius;
  floor.gap = [radius](const VectorX& q) { return q[2] - radius; };
  floor.normal = [](const VectorX& q) {
    VectorX w = VectorX::Zero(q.size() - 1);  // free body: nq = 7, nv = 6
    w[2] = 1.0;
    return w;
  };
  floor.restitution = parameters.restitution;
  return {floor};
}

std::vector<double> bouncingBallReferenceImpacts(const BouncingBallParameters& parameters,
                                                 double t_end) {
  const Scene scene = bouncingBall(parameters);
  EventDrivenReference reference(scene.model, bouncingBallConstraints(parameters));
  reference.reset(0.0, scene.q0, scene.v0);
  reference.advanceTo(t_end);
  std::vector<double> times;
  for (const Impact& impact : reference.impacts()) times.push_back(impact.t);
  return times;
}

std::vector<ConvergencePoint> bouncingBallConvergence(const BouncingBallParameters& parameters,
                                                      Scheme scheme,
                                                      const std::vector<double>& steps,
                                                      double t_end, double sample_interval) {
  const Scene scene = bouncingBall(parameters);
  const long samples = wholeRatio(t_end, sample_interval, "t_end / sample_interval");
  std::vector<double> reference_height(samples + 1);
  {
    EventDrivenReference reference(scene.model, bouncingBallConstraints(parameters));
    reference.reset(0.0, scene.q0, scene.v0);
    for (long j = 0; j <= samples; ++j) {
      reference.advanceTo(static_cast<double>(j) * sample_interval);
      reference_height[j] = reference.q()[2];
    }
  }
  return convergenceStudy(steps, [&](double h) {
    return sampledRms(scene, scheme, h, sample_interval, samples, [&](const VectorX& q, long j) {
      const double d = q[2] - reference_height[j];
      return d * d;
    });
  });
}

RockingImpact rockingBlockFirstImpact(const RockingBlockParameters& parameters, Scheme scheme,
                                      double h, int threshold_updates) {
  const Scene scene = rockingBlock(parameters);
  SchemeSettings settings = tightSettings(scheme, h);
  settings.friction.threshold_updates = threshold_updates;
  TimeStepper stepper(scene.model, scene.cmodel, settings);
  stepper.reset(0.0, scene.q0, scene.v0);
  // the bottom-left corner (-b, -c) is the one that hits the floor first
  // (its x in world: explicit components, which GCC 12's dangling-pointer check accepts)
  auto leftCornerX = [&](const VectorX& q) {
    return q[0] - std::cos(q[2]) * parameters.half_width + std::sin(q[2]) * parameters.half_height;
  };
  for (int k = 0; k < 40000; ++k) {
    const double before = stepper.v()[2];
    const double corner_before = leftCornerX(stepper.q());
    stepper.step();
    const double after = stepper.v()[2];
    if (std::abs(before) > 0.05 && std::abs(after) < 0.8 * std::abs(before))
      return {after / before, std::abs(leftCornerX(stepper.q()) - corner_before)};
  }
  return {std::nan(""), 0.0};
}

WallPendulumReference wallPendulumReference(const WallPendulumParameters& parameters, double t_end,
                                            double sample_interval) {
  const Scene scene = wallPendulum(parameters);
  const long samples = wholeRatio(t_end, sample_interval, "t_end / sample_interval");
  EventDrivenReference reference(scene.model, wallPendulumConstraints(parameters));
  reference.reset(0.0, scene.q0, scene.v0);
  WallPendulumReference out;
  Data data(scene.model);
  out.energy_start = totalEnergy(scene.model, data, scene.q0, scene.v0);
  for (long j = 0; j <= samples; ++j) {
    reference.advanceTo(static_cast<double>(j) * sample_interval);
    out.q.push_back(reference.q());
    out.v.push_back(reference.v());
  }
  out.energy_end = totalEnergy(scene.model, data, reference.q(), reference.v());
  out.impacts = reference.impacts();
  out.phases = reference.phases();
  return out;
}

std::vector<ConvergencePoint> wallPendulumConvergence(const WallPendulumParameters& parameters,
                                                      Scheme scheme,
                                                      const std::vector<double>& steps,
                                                      double t_end, double sample_interval) {
  const Scene scene = wallPendulum(parameters);
  const WallPendulumReference reference = wallPendulumReference(parameters, t_end, sample_interval);
  const long samples = static_cast<long>(reference.q.size()) - 1;
  return convergenceStudy(steps, [&](double h) {
    return sampledRms(scene, scheme, h, sample_interval, samples,
                      [&](const VectorX& q, long j) { return (q - reference.q[j]).squaredNorm(); });
  });
}

std::vector<ConvergencePoint> rampForceConvergence(const SceneFile& file, Scheme scheme,
                                                   const std::vector<double>& steps, double k,
                                                   double mu, double mass) {
  const Scene scene = buildSceneFile(file);
  const double t_end = file.run.t_end, g = -file.spec.gravity.y();
  const double t_star = mu * mass * g / k;
  const double exact = k * std::pow(t_end - t_star, 3) / (6.0 * mass);
  return convergenceStudy(steps, [&](double h) {
    const long count = wholeRatio(t_end, h, "t_end / h");
    TimeStepper stepper(scene.model, scene.cmodel, tightSettings(scheme, h), scene.forces);
    stepper.reset(0.0, scene.q0, scene.v0);
    for (long n = 0; n < count; ++n) stepper.step();
    return std::abs(stepper.q()[0] - scene.q0[0] - exact);
  });
}

std::vector<ConvergencePoint> rockingBlockConvergence(const RockingBlockParameters& parameters,
                                                      Scheme scheme,
                                                      const std::vector<double>& steps) {
  return convergenceStudy(steps, [&](double h) {
    return std::abs(rockingBlockFirstImpact(parameters, scheme, h).ratio -
                    housnerRatio(parameters));
  });
}

std::vector<ConvergencePoint> painleveJamConvergence(const SceneFile& file,
                                                     const std::vector<double>& steps) {
  const Scene scene = buildSceneFile(file);
  return convergenceStudy(steps, [&](double h) {
    TimeStepper stepper(scene.model, scene.cmodel, tightSettings(Scheme::MoreauJean, h),
                        scene.forces);
    stepper.reset(0.0, scene.q0, scene.v0);
    stepper.step();
    if (stepper.impulses().size() != 1)
      throw std::runtime_error("V7: expected one contact in the first step");
    const Vector3& P = stepper.impulses()[0];
    return std::hypot(P.x() - 0.3, std::abs(P.y()) - 0.4);
  });
}

SliderCrankRun sliderCrankRun(const SliderCrankParameters& parameters, Scheme scheme, double h,
                              double t_end) {
  const Scene scene = sliderCrank(parameters);
  SchemeSettings settings = tightSettings(scheme, h);
  // 1e-10: the impulses here are ~1e-3 N s; 1e-12 would only add sweeps
  settings.coulomb.tolerance = settings.normal_stage.tolerance = settings.friction_stage.tolerance =
      1e-10;
  TimeStepper stepper(scene.model, scene.cmodel, settings);
  stepper.reset(0.0, scene.q0, scene.v0);
  SliderCrankRun run;
  run.energy_start = run.energy_highest = stepper.energy();
  const long count = wholeRatio(t_end, h, "t_end / h");
  for (long k = 0; k < count; ++k) {
    const StepStats& stats = stepper.step();
    run.energy_highest = std::max(run.energy_highest, stepper.energy());
    run.contact_work += stats.work_normal + stats.work_tangent;
    run.contact_steps += stats.active > 0;
    run.cap_hits += stats.cap_hit;
    run.penetration_max = std::max(run.penetration_max, stats.penetration_max);
  }
  run.energy_end = stepper.energy();
  const VectorX& q = stepper.q();
  run.theta = Vector3(q[0], q[0] + q[1], q[0] + q[1] + q[2]);
  return run;
}

WoodpeckerRun woodpeckerRun(const WoodpeckerParameters& parameters, Scheme scheme, double h,
                            double t_end, int threshold_updates) {
  const Scene scene = woodpecker(parameters);
  SchemeSettings settings = tightSettings(scheme, h);
  settings.friction.threshold_updates = threshold_updates;
  settings.coulomb.tolerance = settings.normal_stage.tolerance = settings.friction_stage.tolerance =
      1e-10;
  TimeStepper stepper(scene.model, scene.cmodel, settings, scene.forces);
  stepper.reset(0.0, scene.q0, scene.v0);
  // the stepper's energy has gravity; the spring's lives in the scene's forces
  auto energy = [&] {
    const double twist = stepper.q()[2];
    return stepper.energy() + 0.5 * parameters.c_phi * twist * twist;
  };
  int beak = -1;
  for (int g = 0; g < scene.cmodel.size(); ++g)
    if (scene.cmodel.geometries[g].name == "beak") beak = g;
  WoodpeckerRun run;
  run.energy_start = energy();
  double previous = run.energy_start;
  const long count = wholeRatio(t_end, h, "t_end / h");
  for (long k = 0; k < count; ++k) {
    const StepStats& stats = stepper.step();
    const double now = energy();
    run.largest_step_rise = std::max(run.largest_step_rise, now - previous);
    previous = now;
    run.contact_work += stats.work_normal + stats.work_tangent;
    run.cap_hits += stats.cap_hit;
    const std::vector<Contact>& contacts = stepper.contactData().contacts;
    for (std::size_t c = 0; c < stepper.impulses().size() && c < contacts.size(); ++c) {
      const bool on_beak = contacts[c].key.geometry_a == beak || contacts[c].key.geometry_b == beak;
      if (!on_beak || stepper.impulses()[c].x() <= 0.0) continue;
      if (run.beak_times.empty() || stepper.time() - run.beak_times.back() > 5e-3) {
        run.beak_times.push_back(stepper.time());
        run.beak_heights.push_back(stepper.q()[0]);
      }
    }
  }
  run.energy_end = energy();
  run.y_end = stepper.q()[0];
  return run;
}

}  // namespace sweep
