// Stage 6 of a step (time_stepper.hpp), q_{k+1} = q_m + h/2 v_{k+1} with the contacts' work,
// and the checks after it: a body that ran away, and the energies and penetrations at q_{k+1}.
#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>

#include "framework/configuration.hpp"
#include "framework/energy.hpp"
#include "framework/error.hpp"
#include "framework/kinematics.hpp"
#include "framework/parallel.hpp"
#include "integrators/rows.hpp"
#include "integrators/time_stepper.hpp"

namespace sweep {
namespace stepping {

void checkRunaway(const StepModel& m, const StepData& d) {
  // A body tree whose kinetic energy is that of its mass crossing the scene kRunawayExtents
  // times in one step has run away (a diverging solve or position correction), long before its
  // coordinates grow large enough to break the collision library's bounding boxes.
  constexpr double kRunawayExtents = 100.0;
  if (!(d.scene_extent > 0.0)) return;
  const double speed = kRunawayExtents * d.scene_extent / m.h();
  // the trees the step moved (Data::componentSubset): the others' velocities are not this
  // process's to check
  const std::vector<int>* subset = d.model_data.componentSubset();
  const int trees = subset != nullptr
                        ? static_cast<int>(subset->size())
                        : static_cast<int>(m.model.components.size() - m.model.systems.size());
  for (int k = 0; k < trees; ++k) {
    const int c = subset != nullptr ? (*subset)[k] : k;
    const Component& comp = m.model.components[c];
    const double mass = m.component_mass[c];
    if (comp.nv == 0 || !(mass > 0.0)) continue;
    const MatrixX& M = d.model_data.mass_blocks[c];  // at the step's midpoint
    double twice_kinetic = 0.0;
    if (comp.nv == 6) {  // a free body: a fixed-size product, no temporary
      const auto v_c = d.v.segment<6>(comp.v_index);
      twice_kinetic = v_c.dot(Eigen::Map<const Matrix6>(M.data()) * v_c);
    } else {
      const auto v_c = d.v.segment(comp.v_index, comp.nv);
      for (int j = 0; j < comp.nv; ++j) twice_kinetic += v_c[j] * M.col(j).dot(v_c);
    }
    if (!(twice_kinetic > mass * speed * speed)) continue;
    const Body& body = m.model.bodies[comp.first_body];
    std::ostringstream out;
    out << "step " << d.stats.step << " (t = " << d.t << " s): body '" << body.name
        << "' has run away: its kinetic energy " << 0.5 * twice_kinetic
        << " J is that of its mass moving at " << std::sqrt(twice_kinetic / mass) << " m/s, over "
        << kRunawayExtents << " times the scene's extent (" << d.scene_extent << " m) per step of "
        << m.h()
        << " s (a diverging solve or position correction, or forces far beyond the scene's "
           "scale)";
    throw RunawayError(out.str());
  }
}

void update(const StepModel& m, StepData& d) {
  const auto start = std::chrono::steady_clock::now();
  if (!m.model.actuators.empty()) actuatorTorques(m, d);
  const int n = d.problem.size();
  // contact work with the local velocities of H(q_m) at the start and end of the step
  d.stats.work_normal = d.stats.work_tangent = 0.0;
  // packed 3D rows (scheme A's powder rows): one pass for U and U_r, the generic reads' sums
  // to the bit (rows without a rolling row carry R = 0)
  const RowReader rows(d.problem, RowReader::kPacked3d | RowReader::kSpheres3d);
  auto velocities = [&](int c, const VectorX& v, Vector3& u, Vector2& u_rolling) {
    rows.visit(c, [&](const auto& row) { row.velocity(v, u, u_rolling); });
  };
  // {normal, tangential} work, summed in chunks of rows: the same bits on any thread count
  using Work = std::array<double, 2>;
  const Work work = reduceInChunks(
      n, m.threads, Work{0.0, 0.0},
      [&](long c, Work& sum) {
        Vector3 u_end, u_start;
        Vector2 rolling_end = Vector2::Zero(), rolling_start = Vector2::Zero();
        velocities(c, d.v_free, u_end, rolling_end);
        const Vector3 u_mean = 0.5 * (d.problem.velocity_start[c] + u_end);
        sum[0] += d.P[c].x() * u_mean.x();
        sum[1] += d.P[c].tail<2>().dot(u_mean.tail<2>());
        if (d.problem.contact[c] >= 0 && d.problem.rolling) {
          velocities(c, d.v, u_start, rolling_start);
          sum[1] += d.R[c].dot(0.5 * (rolling_start + rolling_end));
        }
      },
      [](Work& total, const Work& part) {
        total[0] += part[0];
        total[1] += part[1];
      });
  d.stats.work_normal = work[0];
  d.stats.work_tangent = work[1];
  d.v = d.v_free;
  const std::vector<int>* components = d.model_data.componentSubset();
  integrate(m.model, d.q_m, 0.5 * m.settings.h * d.v, d.q, m.threads, components);
  normalizeConfiguration(m.model, d.q, m.threads, components);
  d.t += m.settings.h;
  d.stats.t = d.t;
  d.stats.t_update = secondsSince(start);
}

void diagnose(const StepModel& m, StepData& d) {
  forwardKinematics(m.model, d.model_data, d.q, d.v);
  d.stats.kinetic = kineticEnergy(m.model, d.model_data);
  d.stats.potential = potentialEnergy(m.model, d.model_data);
  evaluateContactGaps(m.model, d.model_data, m.cmodel, d.contact_data, d.t, d.end_gap);
  struct Penetration {
    double max = 0.0, sum = 0.0;
    long count = 0;
    void add(double g) {
      if (!(g < 0.0)) return;
      max = std::max(max, -g);
      sum += -g;
      ++count;
    }
  };
  Penetration total = reduceInChunks(
      static_cast<long>(d.end_gap.size()), m.threads, Penetration{},
      [&](long c, Penetration& part) { part.add(d.end_gap[c]); },
      [](Penetration& sum, const Penetration& part) {
        sum.max = std::max(sum.max, part.max);
        sum.sum += part.sum;
        sum.count += part.count;
      });
  for (const ConstraintFunction& f : m.model.constraints) total.add(f.gap(d.q));
  d.stats.penetration_max = total.max;
  d.stats.penetration_sum = total.sum;
  d.stats.penetration_count = static_cast<int>(total.count);
}

}  // namespace stepping
}  // namespace sweep
