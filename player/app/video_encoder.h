#pragma once
/// H.264 video from raw RGBA frames, through an `ffmpeg` process fed by a pipe: no PNG
/// in between (encoding a PNG alone costs 100–300 ms a frame). The file appears only
/// when finish() succeeds (ffmpeg writes a temporary beside it, renamed at the end).

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <vector>

#include "common/output_file.h"

namespace fissure::player {

class VideoEncoder {
 public:
  /// Starts ffmpeg. Throws fissure::Error when it cannot be started.
  VideoEncoder(std::filesystem::path path, int width, int height, int fps);
  /// Stops ffmpeg and removes the temporary if finish() was not reached.
  ~VideoEncoder();
  VideoEncoder(const VideoEncoder&) = delete;
  VideoEncoder& operator=(const VideoEncoder&) = delete;

  /// One frame, width × height × 4 bytes, top row first. Throws if ffmpeg has stopped.
  void add(const std::vector<std::uint8_t>& rgba);
  /// Waits for ffmpeg and puts the video in place. Throws fissure::Error naming the
  /// file when ffmpeg failed (its own messages are on stderr above).
  void finish();

  /// Whether an `ffmpeg` program is on the PATH.
  [[nodiscard]] static bool available();

 private:
  std::filesystem::path m_path;
  TemporaryOutput m_temporary;  ///< what ffmpeg writes; removed unless finished
  std::size_t m_frame_bytes;
  std::FILE* m_pipe = nullptr;
};

}  // namespace fissure::player
