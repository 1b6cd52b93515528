// libFuzzer target: VTK snapshots as `sweep view` reads them (apps/sweep/viewer.hpp). Each
// input is the text of one .vtp file; it must be read, or refused with an InputError, with no
// crash, no sanitizer report, no runaway allocation.
#include <cstddef>
#include <cstdint>
#include <string>

#include "apps/sweep/viewer.hpp"
#include "framework/error.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* bytes, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(bytes), size);
  try {
    sweep::readViewerSnapshot("input.vtp", text);
  } catch (const sweep::InputError&) {
  }
  return 0;
}
