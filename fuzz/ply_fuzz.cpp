// libFuzzer target: Fissure's PLY reader (ascii and both binary encodings).
#include <cstddef>
#include <cstdint>

#include "common/error.h"
#include "formats/ply.h"
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    (void)fissure::formats::parse_ply(fissure::fuzz::as_text(data, size), "fuzz.ply");
  } catch (const fissure::Error&) {
  }
  return 0;
}
