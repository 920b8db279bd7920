// libFuzzer target: the player's scene reader (TOML through toml++, then every key's
// validation).
#include <cstddef>
#include <cstdint>

#include "common/error.h"
#include "formats/scene.h"
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    (void)fissure::formats::parse_scene(fissure::fuzz::as_text(data, size), "fuzz.toml");
  } catch (const fissure::Error&) {
  }
  return 0;
}
