// libFuzzer target: render-mesh import through assimp (OBJ, STL, OFF, Collada, SMD, NFF,
// RAW, AC3D, glTF, GLB and a few more of the formats the bake accepts; PLY has its own
// target). The first byte picks the format (its low 7 bits; the high bit welds), since
// assimp picks its reader by the file's extension. Assimp is not instrumented for coverage, so this target mostly
// checks what Fissure does with what assimp returns. Assimp itself runs in a forked
// child first (bake/mesh_import.cpp), under a time and memory budget: a crash or a
// hang inside it is a fissure::Error here, as it is for users, and the child's
// sanitizer report lands in the log without failing the run.
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

#include "bake/mesh_import.h"
#include "common/error.h"
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  static constexpr std::array<const char*, 16> kExtensions = {"obj", "stl", "off", "dae", "smd", "nff", "raw", "ac",
                                                              "gltf", "glb", "x", "ase", "3ds", "ms3d", "md2", "b3d"};
  const std::string name = std::string("mesh.") + kExtensions[(data[0] & 0x7F) % kExtensions.size()];
  const auto path = fissure::fuzz::write_input(fissure::fuzz::as_text(data + 1, size - 1), name);
  try {
    (void)fissure::bake::import_render_mesh(path, {.weld = (data[0] & 0x80) != 0});
  } catch (const fissure::Error&) {
  }
  return 0;
}
