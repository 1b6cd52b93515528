#pragma once
#include <sstream>
#include <stdexcept>
#include <string>

namespace sweep {

// Raised for anything a user supplied that Sweep cannot accept. The message names the source
// (file or builder), the element or field, and the offending value.
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& message) : std::runtime_error(message) {}
};

// Raised by a time step whose state has run away (integrators' checkRunaway): a run that
// catches it can still write its outputs, up to and including that step, and fail.
class RunawayError : public std::runtime_error {
 public:
  explicit RunawayError(const std::string& message) : std::runtime_error(message) {}
};

// A number as messages quote it (default stream format: 0.3, -1e-07).
inline std::string formatValue(double x) {
  std::ostringstream out;
  out << x;
  return out.str();
}

}  // namespace sweep
