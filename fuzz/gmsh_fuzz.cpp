// libFuzzer target: the Gmsh .msh cage reader (2.2 and 4.1 ASCII).
#include <cstddef>
#include <cstdint>

#include "common/error.h"
#include "formats/cage_io.h"
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = fissure::fuzz::write_input(fissure::fuzz::as_text(data, size), "cage.msh");
  try {
    (void)fissure::formats::read_gmsh(path);
  } catch (const fissure::Error&) {
  }
  return 0;
}
