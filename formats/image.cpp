#include "formats/image.h"

#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STB_IMAGE_WRITE_STATIC
#include <stb/stb_image_write.h>
#define STB_IMAGE_IMPLEMENTATION
#define STB_IMAGE_STATIC
#define STBI_ONLY_PNG
#include <stb/stb_image.h>

#include <memory>
#include <string>

#include "common/error.h"
#include "common/output_file.h"

namespace fissure::formats {

namespace {

void append_to_string(void* context, void* data, int size) {
  static_cast<std::string*>(context)->append(static_cast<const char*>(data), static_cast<std::size_t>(size));
}

}  // namespace

void write_png(const std::filesystem::path& path, const Image& image) {
  if (image.width <= 0 || image.height <= 0 ||
      image.rgba.size() != 4 * static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height)) {
    throw Error(path.string() + ": the image is " + std::to_string(image.width) + "×" + std::to_string(image.height) +
                    " with " + std::to_string(image.rgba.size()) + " bytes",
                "this is a bug; please report it");
  }
  std::string bytes;
  const int ok = stbi_write_png_to_func(append_to_string, &bytes, image.width, image.height, 4, image.rgba.data(),
                                        4 * image.width);
  if (ok == 0) throw Error(path.string() + ": cannot encode the image", "this is a bug; please report it");
  // No fsync: frames are cheap to remake, and a run writes hundreds of them.
  write_file_atomically(path, bytes, /*sync=*/false);
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
