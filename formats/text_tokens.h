#pragma once
/// Whitespace-separated tokens of a text file with their line numbers, for the
/// ASCII cage formats. Every parse error names the file and line. '#' starts a
/// comment to the end of the line (TetGen, MEDIT; never valid inside Gmsh data).

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace fissure::formats {

class TextTokens {
 public:
  /// Reads the whole file. Throws fissure::Error if it is missing, unreadable or empty.
  explicit TextTokens(const std::filesystem::path& path);

  [[nodiscard]] bool at_end() const { return m_next >= m_tokens.size(); }
  /// Line of the token that `next` returns, or of the last token at the end.
  [[nodiscard]] std::size_t line() const;
  [[nodiscard]] const std::string& file() const { return m_file; }

  [[nodiscard]] std::string_view peek() const;
  std::string_view next(std::string_view what);
  double next_double(std::string_view what);
  std::int64_t next_integer(std::string_view what);
  /// An integer in [0, limit) after subtracting `base`; the error names `what`.
  std::size_t next_count(std::string_view what);
  /// A record count from a header, checked against what the file still holds: each
  /// record takes at least `tokens_per_record` tokens. A bogus or truncated header
  /// is an error naming the line, never a huge allocation.
  std::size_t next_record_count(std::string_view what, std::size_t tokens_per_record);
  [[nodiscard]] std::size_t remaining() const { return m_tokens.size() - m_next; }
  /// Skips tokens up to the end of the current line (TetGen's optional columns).
  void skip_rest_of_line();

  /// "file:line" of the token read last, for errors the caller finds in it.
  [[nodiscard]] std::string where() const;

 private:
  struct Token {
    std::size_t begin, length, line;
  };
  std::string m_file;
  std::string m_text;
  std::vector<Token> m_tokens;
  std::size_t m_next = 0;
};

}  // namespace fissure::formats
