#include "common/error.h"

namespace fissure {

Error::Error(const std::string& message, std::string hint)
    : std::runtime_error(message), m_hint(std::move(hint)) {}

std::string quote_from_file(std::string_view raw, std::size_t max_bytes, char quote) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string text(1, quote);
  for (std::size_t i = 0; i < raw.size() && i < max_bytes; ++i) {
    const auto byte = static_cast<unsigned char>(raw[i]);
    if (byte >= 0x20 && byte < 0x7f && byte != '\\' && byte != static_cast<unsigned char>(quote)) {
      text += static_cast<char>(byte);
    } else {
      text += "\\x";
      text += kHex[byte >> 4];
      text += kHex[byte & 15];
    }
  }
  text += quote;
  if (raw.size() > max_bytes) text += "...";
  return text;
}

std::string format_error(const Error& error) {
  std::string text = "error: ";
  text += error.what();
  text += '\n';
  if (!error.hint().empty()) {
    text += "hint: ";
    text += error.hint();
    text += '\n';
  }
  return text;
}

}  // namespace fissure
