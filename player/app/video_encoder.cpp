#include "player/app/video_encoder.h"

#include <csignal>
#include <cstdlib>
#include <string>

#include "common/error.h"

namespace fissure::player {

namespace {

/// `text` as one word for /bin/sh.
std::string shell_quoted(const std::string& text) {
  std::string out = "'";
  for (const char c : text) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

}  // namespace

bool VideoEncoder::available() { return std::system("command -v ffmpeg >/dev/null 2>&1") == 0; }

VideoEncoder::VideoEncoder(std::filesystem::path path, int width, int height, int fps)
    : m_path(std::move(path)),
      m_temporary(m_path),
      m_frame_bytes(4 * static_cast<std::size_t>(width) * static_cast<std::size_t>(height)) {
  if (!available()) {
    throw Error("--video " + m_path.string() + ": ffmpeg is not installed", "install it (apt-get install ffmpeg), or write --frames");
  }
  // A dead ffmpeg must surface as a write error here, not kill the player.
  std::signal(SIGPIPE, SIG_IGN);
  // libx264 with yuv420p needs even sizes: pad by a pixel where needed.
  const std::string command =
      "ffmpeg -hide_banner -loglevel error -y -f rawvideo -pix_fmt rgba -s " + std::to_string(width) + "x" +
      std::to_string(height) + " -r " + std::to_string(fps) +
      " -i - -vf 'pad=ceil(iw/2)*2:ceil(ih/2)*2' -c:v libx264 -preset veryfast -crf 20 -pix_fmt yuv420p"
      " -movflags +faststart -f mp4 " + shell_quoted(m_temporary.path().string());
  m_pipe = popen(command.c_str(), "w");
  if (m_pipe == nullptr) throw Error("--video " + m_path.string() + ": cannot start ffmpeg", "check ffmpeg runs");
}

VideoEncoder::~VideoEncoder() {
  if (m_pipe == nullptr) return;
  pclose(m_pipe);
}

void VideoEncoder::add(const std::vector<std::uint8_t>& rgba) {
  if (rgba.size() != m_frame_bytes || std::fwrite(rgba.data(), 1, rgba.size(), m_pipe) != rgba.size()) {
    throw Error("--video " + m_path.string() + ": ffmpeg stopped taking frames", "see ffmpeg's messages above");
  }
}

void VideoEncoder::finish() {
  const int status = pclose(m_pipe);
  m_pipe = nullptr;
  if (status != 0) {
    throw Error("--video " + m_path.string() + ": ffmpeg failed (status " + std::to_string(status) + ")",
                "see ffmpeg's messages above; check the folder is writable");
  }
  m_temporary.commit();
}

}  // namespace fissure::player
