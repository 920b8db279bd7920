#pragma once
/// Image comparison with tolerances, after Filament's imagediff: a pixel of `actual`
/// passes when some pixel of `expected` within `shift` pixels matches it to `max_abs` in
/// every channel; the images match when at most `max_failing_fraction` of the pixels
/// fail. Renders are never compared byte for byte across Mesa versions
/// (docs/decisions/0037-rendering-embedded-instances.md).

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "formats/image.h"

namespace fissure::testing {

struct ImageTolerance {
  int max_abs = 8;                     ///< per channel, of 255
  int shift = 1;                       ///< pixels
  double max_failing_fraction = 1e-3;
};

struct ImageDifference {
  std::size_t failing = 0;
  std::size_t pixels = 0;
  [[nodiscard]] double fraction() const { return pixels == 0 ? 1.0 : static_cast<double>(failing) / pixels; }
};

inline bool pixels_match(const formats::Image& a, int ax, int ay, const formats::Image& b, int bx, int by, int max_abs) {
  const std::size_t i = 4 * (static_cast<std::size_t>(ay) * a.width + ax), j = 4 * (static_cast<std::size_t>(by) * b.width + bx);
  for (int c = 0; c < 4; ++c) {
    if (std::abs(int(a.rgba[i + c]) - int(b.rgba[j + c])) > max_abs) return false;
  }
  return true;
}

/// Compares; writes `diff` (failing pixels red over a faded `expected`) when it is given
/// and some pixel fails.
inline ImageDifference compare_images(const formats::Image& actual, const formats::Image& expected,
                                      const ImageTolerance& tolerance, const std::filesystem::path& diff = {}) {
  ImageDifference d;
  if (actual.width != expected.width || actual.height != expected.height) {
    d.pixels = d.failing = 1;
    return d;
  }
  d.pixels = static_cast<std::size_t>(actual.width) * actual.height;
  formats::Image marked = expected;
  for (int y = 0; y < actual.height; ++y) {
    for (int x = 0; x < actual.width; ++x) {
      bool ok = false;
      for (int dy = -tolerance.shift; dy <= tolerance.shift && !ok; ++dy) {
        for (int dx = -tolerance.shift; dx <= tolerance.shift && !ok; ++dx) {
          const int ex = x + dx, ey = y + dy;
          if (ex < 0 || ey < 0 || ex >= expected.width || ey >= expected.height) continue;
          ok = pixels_match(actual, x, y, expected, ex, ey, tolerance.max_abs);
        }
      }
      std::uint8_t* p = &marked.rgba[4 * (static_cast<std::size_t>(y) * marked.width + x)];
      if (ok) {
        for (int c = 0; c < 3; ++c) p[c] = static_cast<std::uint8_t>(128 + p[c] / 2);
      } else {
        ++d.failing;
        p[0] = 255;
        p[1] = p[2] = 0;
      }
    }
  }
  if (d.failing > 0 && !diff.empty()) formats::write_png(diff, marked);
  return d;
}

/// Pixels that show `background` in `actual` where `expected` shows a surface all
/// around them (the pixel and its 8 neighbours): holes inside a silhouette, not a
/// silhouette's edge moved by a pixel.
inline std::size_t holes(const formats::Image& actual, const formats::Image& expected, const std::uint8_t background[3]) {
  const auto is_background = [&](const formats::Image& image, int x, int y) {
    const std::uint8_t* p = &image.rgba[4 * (static_cast<std::size_t>(y) * image.width + x)];
    return std::equal(background, background + 3, p);
  };
  std::size_t count = 0;
  for (int y = 1; y + 1 < actual.height; ++y) {
    for (int x = 1; x + 1 < actual.width; ++x) {
      if (!is_background(actual, x, y)) continue;
      bool surrounded = true;
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) surrounded = surrounded && !is_background(expected, x + dx, y + dy);
      }
      count += surrounded ? 1 : 0;
    }
  }
  return count;
}

}  // namespace fissure::testing
