// libFuzzer target: the TetGen .node/.ele pair reader. One input holds both files,
// the .node text, a NUL byte, then the .ele text (fuzz/corpus/tetgen holds seeds in
// that form); an input without a NUL is a .node with an empty .ele.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "common/error.h"
#include "formats/cage_io.h"
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view input = fissure::fuzz::as_text(data, size);
  const std::size_t split = input.find('\0');
  const std::string_view node = input.substr(0, split);
  const std::string_view ele = split == std::string_view::npos ? std::string_view{} : input.substr(split + 1);
  const auto node_path = fissure::fuzz::write_input(node, "cage.node");
  const auto ele_path = fissure::fuzz::write_input(ele, "cage.ele");
  try {
    (void)fissure::formats::read_tetgen(node_path, ele_path);
  } catch (const fissure::Error&) {
  }
  return 0;
}
