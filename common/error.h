#pragma once
/// The one exception type for bad input (files, options, scene values).
/// The message names the file and the line, element or key; the hint says what to
/// do, when a fix is known. CLIs print both and exit 1.

#include <stdexcept>
#include <string>

namespace fissure {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message, std::string hint = {});

  /// What to do about it; may be empty.
  [[nodiscard]] const std::string& hint() const noexcept { return m_hint; }

 private:
  std::string m_hint;
};

/// "error: <what>\nhint: <hint>\n" as the CLIs print it.
std::string format_error(const Error& error);

}  // namespace fissure
