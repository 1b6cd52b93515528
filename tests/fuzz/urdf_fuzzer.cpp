// libFuzzer target: URDF text (docs/robustness.md). Any input must end in a Model or an
// InputError naming what is wrong; a Model is then put through the dynamics at its neutral
// configuration (mass matrix, forward dynamics), where a bad inertia would show.
#include <cstddef>
#include <cstdint>
#include <string>

#include "framework/dynamics.hpp"
#include "framework/error.hpp"
#include "framework/urdf_import.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* bytes, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(bytes), size);
  try {
    sweep::ModelBuilder builder("fuzz");
    sweep::addUrdfString(builder, text, "fuzz.urdf");
    const sweep::Model model = builder.build();
    if (model.nv == 0 || model.nv > 500) return 0;
    sweep::Data data(model);
    const sweep::VectorX q = model.neutralConfiguration();
    const sweep::VectorX v = sweep::VectorX::Ones(model.nv);
    const sweep::VectorX tau = sweep::VectorX::Zero(model.nv);
    sweep::forwardDynamics(model, data, q, v, tau);
  } catch (const sweep::InputError&) {
  }
  return 0;
}
