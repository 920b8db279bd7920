// libFuzzer target: render-mesh import through assimp (OBJ, STL, OFF; PLY has its own
// target). The first byte picks the format, since assimp picks its reader by the
// file's extension. Assimp is not instrumented for coverage, so this target mostly
// checks what Fissure does with what assimp returns. Assimp itself runs in a forked
// child first (bake/mesh_import.cpp): a crash inside it is a fissure::Error here, as
// it is for users, and the child's sanitizer report lands in the log without failing
// the run.
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

#include "bake/mesh_import.h"
#include "common/error.h"
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  static constexpr std::array<const char*, 3> kExtensions = {"obj", "stl", "off"};
  const std::string name = std::string("mesh.") + kExtensions[data[0] % kExtensions.size()];
  const auto path = fissure::fuzz::write_input(fissure::fuzz::as_text(data + 1, size - 1), name);
  try {
    (void)fissure::bake::import_render_mesh(path, {.weld = (data[0] & 0x80) != 0});
  } catch (const fissure::Error&) {
  }
  return 0;
}
