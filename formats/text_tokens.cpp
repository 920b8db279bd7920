#include "formats/text_tokens.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

#include "common/error.h"
#include "common/input_file.h"

namespace fissure::formats {

TextTokens::TextTokens(const std::filesystem::path& path) : m_file(path.string()) {
  m_text = read_input_file(path);

  std::size_t line = 1;
  std::size_t i = 0;
  const std::size_t n = m_text.size();
  while (i < n) {
    const char c = m_text[i];
    if (c == '\n') {
      ++line;
      ++i;
    } else if (c == '#') {
      while (i < n && m_text[i] != '\n') ++i;
    } else if (c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v') {
      ++i;
    } else {
      const std::size_t begin = i;
      while (i < n && m_text[i] != '\n' && m_text[i] != '#' && m_text[i] != ' ' && m_text[i] != '\t' &&
             m_text[i] != '\r') {
        ++i;
      }
      m_tokens.push_back({begin, i - begin, line});
    }
  }
  if (m_tokens.empty()) throw Error(m_file + ": the file is empty (no data, only blanks or comments)");
}

std::size_t TextTokens::line() const {
  if (m_tokens.empty()) return 0;
  return m_next < m_tokens.size() ? m_tokens[m_next].line : m_tokens.back().line;
}

std::string TextTokens::where() const {
  const std::size_t last = m_next > 0 ? m_tokens[m_next - 1].line : line();
  return m_file + ":" + std::to_string(last);
}

std::string_view TextTokens::peek() const {
  if (at_end()) return {};
  const Token& t = m_tokens[m_next];
  return std::string_view(m_text).substr(t.begin, t.length);
}

std::string_view TextTokens::next(std::string_view what) {
  if (at_end()) {
    throw Error(where() + ": unexpected end of file while reading " + std::string(what),
                "the file looks truncated; re-export it");
  }
  const std::string_view token = peek();
  ++m_next;
  return token;
}

double TextTokens::next_double(std::string_view what) {
  const std::size_t at = line();
  const std::string_view token = next(what);
  double value = 0.0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (ec != std::errc() || end != token.data() + token.size()) {
    throw Error(m_file + ":" + std::to_string(at) + ": expected a number for " + std::string(what) + ", found " +
                quote_from_file(token));
  }
  if (!std::isfinite(value)) {
    throw Error(m_file + ":" + std::to_string(at) + ": " + std::string(what) + " is not finite (" +
                    quote_from_file(token) + ")",
                "NaN and Inf coordinates cannot be embedded; fix the exporter");
  }
  return value;
}

std::int64_t TextTokens::next_integer(std::string_view what) {
  const std::size_t at = line();
  const std::string_view token = next(what);
  std::int64_t value = 0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (ec != std::errc() || end != token.data() + token.size()) {
    throw Error(m_file + ":" + std::to_string(at) + ": expected an integer for " + std::string(what) + ", found " +
                quote_from_file(token));
  }
  return value;
}

std::size_t TextTokens::next_count(std::string_view what) {
  const std::size_t at = line();
  const std::int64_t value = next_integer(what);
  if (value < 0) {
    throw Error(m_file + ":" + std::to_string(at) + ": " + std::string(what) + " is negative (" +
                std::to_string(value) + ")");
  }
  return static_cast<std::size_t>(value);
}

std::size_t TextTokens::next_record_count(std::string_view what, std::size_t tokens_per_record) {
  const std::size_t count = next_count(what);
  const std::size_t available = remaining() / std::max<std::size_t>(tokens_per_record, 1);
  if (count > available) {
    throw Error(where() + ": the header announces " + std::to_string(count) + " for " + std::string(what) +
                    " but the file holds at most " + std::to_string(available),
                "the file is truncated or its header is wrong; re-export it");
  }
  return count;
}

void TextTokens::skip_rest_of_line() {
  if (m_next == 0) return;
  const std::size_t current = m_tokens[m_next - 1].line;
  while (!at_end() && m_tokens[m_next].line == current) ++m_next;
}

}  // namespace fissure::formats
