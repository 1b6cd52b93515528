// A run's summary: the iteration counts' distribution and summary.json.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "apps/sweep/run.hpp"

namespace sweep {

Distribution distributionOf(const std::vector<int>& values) {
  IterationHistogram histogram;
  for (int v : values) histogram.add(v);
  return histogram.distribution();
}

Distribution IterationHistogram::distribution() const {
  Distribution d;
  long n = 0;
  double sum = 0.0;
  for (const auto& [value, count] : counts_) {
    n += count;
    sum += static_cast<double>(value) * static_cast<double>(count);
  }
  if (n == 0) return d;
  d.mean = sum / static_cast<double>(n);
  // nearest-rank percentiles
  auto rank = [&](double p) {
    const auto k = std::clamp<long>(static_cast<long>(std::ceil(p * static_cast<double>(n))), 1, n);
    long seen = 0;
    for (const auto& [value, count] : counts_) {
      seen += count;
      if (seen >= k) return static_cast<double>(value);
    }
    return static_cast<double>(counts_.rbegin()->first);
  };
  d.p50 = rank(0.50);
  d.p95 = rank(0.95);
  d.p99 = rank(0.99);
  d.max = counts_.rbegin()->first;
  return d;
}
std::string jsonText(const nlohmann::ordered_json& json) {
  // a NaN or an infinity is written as null: JSON has no other spelling for them
  return json.dump(2) + "\n";
}

nlohmann::ordered_json summaryJson(const RunSummary& s) {
  auto distribution = [](const Distribution& d) {
    return nlohmann::ordered_json{
        {"mean", d.mean}, {"p50", d.p50}, {"p95", d.p95}, {"p99", d.p99}, {"max", d.max}};
  };
  nlohmann::ordered_json j;
  j["scheme"] = s.scheme;
  if (!s.failure.empty()) j["failure"] = s.failure;
  j["threads"] = s.threads;
  j["dt"] = s.dt;
  j["t_end"] = s.t_end;
  j["t_reached"] = s.t_reached;
  j["steps"] = s.steps;
  j["interrupted"] = s.interrupted;
  j["cpu_seconds"] = s.cpu_seconds;
  j["wall_seconds"] = s.wall_seconds;
  const double size = s.smallest_size > 0.0 ? s.smallest_size : std::nan("");
  j["penetration"] = {{"cumulative", s.penetration_cumulative},
                      {"time_integral", s.penetration_time_integral},
                      {"peak", s.penetration_peak},
                      {"mean_per_contact", s.penetration_mean},
                      {"smallest_size", s.smallest_size},
                      {"peak_of_smallest_size", s.penetration_peak / size},
                      {"mean_of_smallest_size", s.penetration_mean / size}};
  nlohmann::ordered_json iterations = distribution(s.iterations);
  iterations["cap_hit_steps"] = s.cap_hit_steps;
  iterations["stage1"] = distribution(s.iterations_stage1);
  iterations["stage2"] = distribution(s.iterations_stage2);
  j["iterations"] = iterations;
  j["contacts"] = {{"mean_active", s.mean_active},
                   {"max_active", s.max_active},
                   {"mean_candidates", s.mean_candidates},
                   {"mean_solves", s.mean_solves},
                   {"max_solves", s.max_solves},
                   {"redetection_steps", s.redetection_steps},
                   {"margin_outrun_steps", s.margin_outrun_steps},
                   {"projection_steps", s.projection_steps},
                   {"projection_rounds", s.projection_rounds},
                   {"projection_iterations", s.projection_iterations}};
  j["solver"] = {{"updates", s.updates},
                 {"solve_seconds", s.solve_seconds},
                 {"ns_per_update",
                  s.updates > 0 ? 1e9 * s.solve_seconds / static_cast<double>(s.updates) : 0.0}};
  j["energy"] = {{"initial", s.energy_initial}, {"final", s.energy_final}};
  if (!s.actuators.empty()) j["actuators"] = actuatorsJson(s.actuators);
  if (s.ranks > 1)
    j["ranks"] = {{"count", s.ranks},
                  {"bytes_per_step", s.bytes_per_step},
                  {"shared_bodies_per_step", s.shared_bodies_per_step},
                  {"imbalance_max", s.imbalance_max}};
  return j;
}

void writeSummaryJson(const RunSummary& s, const std::string& path) {
  writeFileAtomically(path, jsonText(summaryJson(s)));
}

}  // namespace sweep
