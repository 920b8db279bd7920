// libFuzzer target: the MEDIT .mesh cage reader.
#include <cstddef>
#include <cstdint>

#include "common/error.h"
#include "formats/cage_io.h"
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = fissure::fuzz::write_input(fissure::fuzz::as_text(data, size), "cage.mesh");
  try {
    (void)fissure::formats::read_medit(path);
  } catch (const fissure::Error&) {
  }
  return 0;
}
