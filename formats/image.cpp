#include "formats/image.h"

#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STB_IMAGE_WRITE_STATIC
#include <stb/stb_image_write.h>
#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_STATIC
#define STBI_ONLY_PNG
#include <stb/stb_image.h>

#include <cstdio>
#include <memory>
#include <system_error>

#include "common/error.h"

namespace fissure::formats {

namespace {

void write_to_file(void* context, void* data, int size) {
  std::FILE* file = static_cast<std::FILE*>(context);
  if (std::fwrite(data, 1, static_cast<std::size_t>(size), file) != static_cast<std::size_t>(size)) {
    // stb cannot report it; ferror is checked after.
  }
}

}  // namespace

void write_png(const std::filesystem::path& path, const Image& image) {
  if (image.width <= 0 || image.height <= 0 ||
      image.rgba.size() != 4 * static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height)) {
    throw Error(path.string() + ": the image is " + std::to_string(image.width) + "×" + std::to_string(image.height) +
                    " with " + std::to_string(image.rgba.size()) + " bytes",
                "this is a bug; please report it");
  }
  const std::filesystem::path temporary = path.string() + ".tmp";
  std::FILE* file = std::fopen(temporary.c_str(), "wb");
  if (file == nullptr) {
    throw Error(path.string() + ": cannot create the file", "check the folder exists and is writable");
  }
  const int ok = stbi_write_png_to_func(write_to_file, file, image.width, image.height, 4, image.rgba.data(),
                                        4 * image.width);
  const bool failed = ok == 0 || std::ferror(file) != 0;
  if (std::fclose(file) != 0 || failed) {
    std::error_code ignored;
    std::filesystem::remove(temporary, ignored);
    throw Error(path.string() + ": cannot write the image", "check the disk has space and the folder is writable");
  }
  std::filesystem::rename(temporary, path);
}

Image read_png(const std::filesystem::path& path) {
  int width = 0, height = 0, channels = 0;
  const std::unique_ptr<stbi_uc, void (*)(void*)> pixels(stbi_load(path.c_str(), &width, &height, &channels, 4),
                                                         stbi_image_free);
  if (!pixels) {
    throw Error(path.string() + ": cannot read the image (" + (stbi_failure_reason() ? stbi_failure_reason() : "?") + ")",
                "check the file exists and is a PNG");
  }
  Image image{width, height, {}};
  image.rgba.assign(pixels.get(), pixels.get() + 4 * static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
  return image;
}

}  // namespace fissure::formats
