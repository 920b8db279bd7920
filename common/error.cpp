#include "common/error.h"

namespace fissure {

Error::Error(const std::string& message, std::string hint)
    : std::runtime_error(message), m_hint(std::move(hint)) {}

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
