#pragma once
/// RGBA8 images: PNG files for frames, golden images and diffs (stb, kept inside).

#include <cstdint>
#include <filesystem>
#include <vector>

namespace fissure::formats {

struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgba;  ///< width × height × 4, top row first
};

/// Writes atomically (a temporary beside it, renamed when complete). Throws
/// fissure::Error naming the file.
void write_png(const std::filesystem::path& path, const Image& image);

/// Throws fissure::Error naming the file when it is missing or not an image.
Image read_png(const std::filesystem::path& path);

}  // namespace fissure::formats
