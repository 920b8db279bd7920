#pragma once
/// The one exception type for bad input (files, options, scene values).
/// The message names the file and the line, element or key; the hint says what to
/// do, when a fix is known. CLIs print both and exit 1.

#include <cstddef>
#include <stdexcept>
#include <string>
#include <string_view>

namespace fissure {

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message, std::string hint = {});

  /// What to do about it; may be empty.
  [[nodiscard]] const std::string& hint() const noexcept { return m_hint; }

 private:
  std::string m_hint;
};

/// Text taken from a file, quoted for a message: printable ASCII as it is, other bytes as
/// \xNN (a NUL would end the message where a terminal or what() reads it, and control
/// bytes would garble the terminal), cut to `max_bytes` with "..." after.
std::string quote_from_file(std::string_view raw, std::size_t max_bytes = 40, char quote = '\'');

/// "error: <what>\nhint: <hint>\n" as the CLIs print it.
std::string format_error(const Error& error);

}  // namespace fissure
