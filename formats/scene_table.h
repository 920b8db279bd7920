#pragma once
/// The scene reader's view of a TOML table (formats/scene.cpp's internals, not an API):
/// typed reads with range checks, unknown keys refused with a suggestion, and every
/// error naming the file, the line and the full key. Included by scene.cpp alone, so
/// toml++ stays inside that one translation unit.

#include <toml++/toml.h>

#include <algorithm>
#include <charconv>
#include <climits>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <optional>
#include <sstream>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "common/error.h"
#include "common/types.h"

namespace fissure::formats::scene_detail {

inline std::string format_number(double value) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, result.ptr);
}

inline std::string format_vec3(const Vec3& v) {
  return "[" + format_number(v.x()) + ", " + format_number(v.y()) + ", " + format_number(v.z()) + "]";
}

/// "a string", "an integer", ... for type errors.
inline std::string describe_type(const toml::node& node) {
  switch (node.type()) {
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a floating-point number";
    case toml::node_type::boolean: return "a boolean";
    case toml::node_type::array: return "an array";
    case toml::node_type::table: return "a table";
    case toml::node_type::date: return "a date";
    case toml::node_type::time: return "a time";
    case toml::node_type::date_time: return "a date-time";
    case toml::node_type::none: break;
  }
  return "nothing";
}

/// A TOML string (valid UTF-8, toml++ checks) as it is, unless it holds control
/// characters ("\u0000" is legal TOML), which would cut or garble the message.
inline std::string show_string(const std::string& text) {
  const bool plain = std::none_of(text.begin(), text.end(), [](char c) { return static_cast<unsigned char>(c) < 0x20 || c == 0x7f; });
  return plain ? "\"" + text + "\"" : quote_from_file(text, 80, '"');
}

/// The value as a TOML reader would recognise it in a message.
inline std::string show(const toml::node& node) {
  if (const auto* s = node.as_string()) return show_string(s->get());
  if (const auto* i = node.as_integer()) return std::to_string(i->get());
  if (const auto* f = node.as_floating_point()) return format_number(f->get());
  if (const auto* b = node.as_boolean()) return b->get() ? "true" : "false";
  if (const auto* a = node.as_array()) {
    std::string text = "[";
    for (std::size_t i = 0; i < a->size(); ++i) text += (i ? ", " : "") + show(*a->get(i));
    return text + "]";
  }
  if (node.is_table()) return "{...}";
  return describe_type(node);
}

inline std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

inline int line_of(const toml::node& node, int fallback) {
  const auto line = node.source().begin.line;
  return line > 0 ? static_cast<int>(line) : fallback;
}

/// Where errors point: the file name as given, plus a line.
class Source {
 public:
  explicit Source(std::string file) : m_file(std::move(file)) {}
  [[noreturn]] void fail(int line, const std::string& message, std::string hint = {}) const {
    throw Error(m_file + ":" + std::to_string(line) + ": " + message, std::move(hint));
  }

 private:
  std::string m_file;
};

/// One TOML table with its dotted path (`object[0].material`) for messages and the
/// header name (`[object.material]`) for hints.
class Table {
 public:
  Table(const Source& source, const toml::table& table, std::string path, std::string header, int fallback_line)
      : m_source(&source), m_table(&table), m_path(std::move(path)), m_header(std::move(header)),
        m_line(scene_detail::line_of(table, fallback_line)) {}

  [[nodiscard]] int line() const { return m_line; }
  [[nodiscard]] const std::string& path() const { return m_path; }
  [[nodiscard]] std::string key_path(std::string_view key) const {
    return m_path.empty() ? std::string(key) : m_path + "." + std::string(key);
  }
  [[nodiscard]] const toml::node* find(std::string_view key) const { return m_table->get(key); }
  [[nodiscard]] int line_of(const toml::node& node) const { return scene_detail::line_of(node, m_line); }
  [[noreturn]] void fail(int line, const std::string& message, std::string hint = {}) const {
    m_source->fail(line, message, std::move(hint));
  }

  /// Unknown keys are errors (a typo would otherwise silently keep a default). The
  /// earliest one in the file is reported.
  void allow_only(std::initializer_list<std::string_view> allowed) const {
    const toml::key* unknown = nullptr;
    for (const auto& [key, node] : *m_table) {
      if (std::find(allowed.begin(), allowed.end(), key.str()) != allowed.end()) continue;
      if (!unknown || key.source().begin.line < unknown->source().begin.line) unknown = &key;
    }
    if (!unknown) return;
    std::string hint;
    std::size_t best = 3;
    for (const auto candidate : allowed) {
      const std::size_t distance = edit_distance(unknown->str(), candidate);
      if (distance < best && distance < unknown->str().size()) {
        best = distance;
        hint = "did you mean '" + std::string(candidate) + "'? ";
      }
    }
    hint += "allowed keys " + (m_header.empty() ? std::string("at the top level") : "in " + m_header) + ": ";
    for (auto it = allowed.begin(); it != allowed.end(); ++it) hint += (it == allowed.begin() ? "" : ", ") + std::string(*it);
    const int line = unknown->source().begin.line > 0 ? static_cast<int>(unknown->source().begin.line) : m_line;
    fail(line, "unknown key " + key_path(unknown->str()), hint);
  }

  [[noreturn]] void fail_missing(std::string_view key, std::string_view example) const {
    fail(m_line, key_path(key) + " is missing",
         "add " + std::string(example) + " to " + (m_header.empty() ? std::string("the file") : m_header));
  }

  /// A finite number (integers accepted) at `node`, named `path` in errors.
  double number_at(const toml::node& node, const std::string& path) const {
    double value = 0;
    if (const auto* i = node.as_integer()) {
      value = static_cast<double>(i->get());
    } else if (const auto* f = node.as_floating_point()) {
      value = f->get();
    } else {
      fail(line_of(node), path + " must be a number, got " + describe_type(node) + " (" + show(node) + ")",
           "write a number without quotes, e.g. " + last_key(path) + " = 0.5");
    }
    if (!std::isfinite(value)) {
      fail(line_of(node), path + " = " + show(node) + " is not finite", "use a finite number");
    }
    return value;
  }

  /// Reads `key` if present and checks it with `ok`; `allowed` describes the range.
  template <typename Ok>
  bool read_number(std::string_view key, double& out, Ok ok, std::string_view allowed) const {
    const toml::node* node = find(key);
    if (!node) return false;
    const double value = number_at(*node, key_path(key));
    if (!ok(value)) fail(line_of(*node), key_path(key) + " = " + show(*node) + " is out of range", "allowed: " + std::string(allowed));
    out = value;
    return true;
  }

  template <typename Ok>
  double require_number(std::string_view key, Ok ok, std::string_view allowed, std::string_view example) const {
    double value = 0;
    if (!read_number(key, value, ok, allowed)) fail_missing(key, example);
    return value;
  }

  std::int64_t integer_at(const toml::node& node, const std::string& path) const {
    const auto* i = node.as_integer();
    if (!i) {
      fail(line_of(node), path + " must be an integer, got " + describe_type(node) + " (" + show(node) + ")",
           "write a whole number without a decimal point or quotes");
    }
    return i->get();
  }

  bool read_integer(std::string_view key, int& out, std::int64_t min, std::int64_t max, std::string_view allowed) const {
    const toml::node* node = find(key);
    if (!node) return false;
    const std::int64_t value = integer_at(*node, key_path(key));
    if (value < min || value > max) {
      fail(line_of(*node), key_path(key) + " = " + show(*node) + " is out of range", "allowed: " + std::string(allowed));
    }
    out = static_cast<int>(value);
    return true;
  }

  bool read_bool(std::string_view key, bool& out) const {
    const toml::node* node = find(key);
    if (!node) return false;
    const auto* b = node->as_boolean();
    if (!b) {
      fail(line_of(*node), key_path(key) + " must be true or false, got " + describe_type(*node) + " (" + show(*node) + ")",
           "write true or false without quotes");
    }
    out = b->get();
    return true;
  }

  std::optional<std::string> read_string(std::string_view key) const {
    const toml::node* node = find(key);
    if (!node) return std::nullopt;
    const auto* s = node->as_string();
    if (!s) {
      fail(line_of(*node), key_path(key) + " must be a string, got " + describe_type(*node) + " (" + show(*node) + ")",
           "put the value in double quotes");
    }
    return s->get();
  }

  template <typename E>
  bool read_choice(std::string_view key, E& out, std::initializer_list<std::pair<std::string_view, E>> choices) const {
    const toml::node* node = find(key);
    if (!node) return false;
    std::string valid;
    for (const auto& [name, value] : choices) valid += (valid.empty() ? "\"" : ", \"") + std::string(name) + "\"";
    const auto* s = node->as_string();
    if (!s) fail(line_of(*node), key_path(key) + " must be a string, got " + describe_type(*node), "one of " + valid);
    for (const auto& [name, value] : choices) {
      if (s->get() == name) {
        out = value;
        return true;
      }
    }
    fail(line_of(*node), key_path(key) + " = " + show(*node) + " is not a valid choice", "one of " + valid);
  }

  Vec3 vec3_at(const toml::node& node, const std::string& path) const {
    const auto* array = node.as_array();
    const std::string hint = "write three numbers, e.g. " + last_key(path) + " = [0, 0, 1]";
    if (!array) fail(line_of(node), path + " must be an array of 3 numbers, got " + describe_type(node) + " (" + show(node) + ")", hint);
    if (array->size() != 3) {
      fail(line_of(node), path + " must have 3 components, got " + std::to_string(array->size()) + " (" + show(node) + ")", hint);
    }
    Vec3 v;
    for (int k = 0; k < 3; ++k) v[k] = number_at(*array->get(static_cast<std::size_t>(k)), path + "[" + std::to_string(k) + "]");
    return v;
  }

  bool read_vec3(std::string_view key, Vec3& out) const {
    const toml::node* node = find(key);
    if (!node) return false;
    out = vec3_at(*node, key_path(key));
    return true;
  }

  /// Reads a vector `key` if present and bounds its length by `max_norm`.
  bool read_vec3(std::string_view key, Vec3& out, double max_norm, std::string_view allowed) const {
    if (!read_vec3(key, out)) return false;
    if (!(out.norm() <= max_norm)) {
      fail(line_of(*find(key)), key_path(key) + " = " + format_vec3(out) + " is out of range", "allowed: " + std::string(allowed));
    }
    return true;
  }

  Vec3 require_vec3(std::string_view key, std::string_view example) const {
    Vec3 v = Vec3::Zero();
    if (!read_vec3(key, v)) fail_missing(key, example);
    return v;
  }

  /// A sub-table (`[a.b]` or `b = { ... }`), if present.
  std::optional<Table> sub_table(std::string_view key, std::string header) const {
    const toml::node* node = find(key);
    if (!node) return std::nullopt;
    const auto* table = node->as_table();
    if (!table) {
      fail(line_of(*node), key_path(key) + " must be a table, got " + describe_type(*node) + " (" + show(*node) + ")",
           "write it as a " + header + " section or as " + std::string(key) + " = { ... }");
    }
    return Table(*m_source, *table, key_path(key), std::move(header), line_of(*node));
  }

  /// Elements of an array of tables (`[[a.b]]`), named `path[i]` in messages.
  /// How many entries of one kind a scene may hold (issue 46): each object is a bundle
  /// loaded and checked, and its spheres meet every other body's; projectiles and
  /// obstacles are tested against every sphere each step. A scene of 1,001 overlapping
  /// objects ran out of memory, and 100,000 boxes took seconds a step.
  static std::size_t max_entries(const std::string& header) {
    if (header == "[object]") return 256;
    if (header == "[projectile]") return 1024;
    return 4096;  // boxes, spheres, pins of one object
  }

  std::vector<Table> table_array(std::string_view key, const std::string& header) const {
    std::vector<Table> tables;
    const toml::node* node = find(key);
    if (!node) return tables;
    const auto* array = node->as_array();
    const std::string hint = "write a [" + header + "] section (double brackets) for each one";
    if (!array) fail(line_of(*node), key_path(key) + " must be an array of tables, got " + describe_type(*node), hint);
    if (const std::size_t most = max_entries(header); array->size() > most) {
      fail(line_of(*array->get(most)), key_path(key) + ": " + std::to_string(array->size()) + " [" + header +
               "] sections, more than the " + std::to_string(most) + " a scene may hold",
           "split the scene, or merge entries; each one costs memory and time every step");
    }
    for (std::size_t i = 0; i < array->size(); ++i) {
      const toml::node& element = *array->get(i);
      const std::string path = key_path(key) + "[" + std::to_string(i) + "]";
      const auto* table = element.as_table();
      if (!table) fail(line_of(element), path + " must be a table, got " + describe_type(element), hint);
      tables.emplace_back(*m_source, *table, path, "[" + header + "]", line_of(element));
    }
    return tables;
  }

 private:
  static std::string last_key(const std::string& path) {
    std::string key = path.substr(path.rfind('.') == std::string::npos ? 0 : path.rfind('.') + 1);
    return key.substr(0, key.find('['));
  }

  const Source* m_source;
  const toml::table* m_table;
  std::string m_path;
  std::string m_header;
  int m_line;
};

}  // namespace fissure::formats::scene_detail
