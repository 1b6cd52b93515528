#include "integrators/solver_settings.hpp"

#include <cmath>

#include "framework/error.hpp"

namespace sweep {

void SolverSettings::validate(const std::string& owner) const {
  const auto show = formatValue;
  if (threads < 1 || threads > 1024)
    throw InputError(owner + ".threads must be in [1, 1024], got " + std::to_string(threads));
  if (parallel_rows < 1)
    throw InputError(owner + ".parallel_rows must be >= 1, got " + std::to_string(parallel_rows));
  if (residual_check_interval < 0)
    throw InputError(owner + ".residual_check_interval must be >= 0, got " +
                     std::to_string(residual_check_interval));
  if (max_iterations < 1)
    throw InputError(owner + ".max_iterations must be >= 1, got " + std::to_string(max_iterations));
  if (!(std::isfinite(tolerance) && tolerance > 0.0))
    throw InputError(owner + ".tolerance must be > 0, got " + show(tolerance));
  if (!(std::isfinite(relaxation) && relaxation > 0.0 && relaxation < 2.0))
    throw InputError(owner + ".relaxation must be in (0, 2), got " + show(relaxation));
}

}  // namespace sweep
