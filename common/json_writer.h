#pragma once
/// A small streaming JSON writer for machine-readable reports (inspect --json,
/// bake options, benchmark tables). Keys keep insertion order, so output is stable.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace fissure {

class JsonWriter {
 public:
  JsonWriter& begin_object();
  JsonWriter& end_object();
  JsonWriter& begin_array();
  JsonWriter& end_array();
  JsonWriter& key(std::string_view name);
  JsonWriter& value(std::string_view text);
  JsonWriter& value(const char* text) { return value(std::string_view(text)); }
  JsonWriter& value(double number);
  JsonWriter& value(std::int64_t number);
  JsonWriter& value(std::uint64_t number);
  JsonWriter& value(int number) { return value(static_cast<std::int64_t>(number)); }
  JsonWriter& value(bool flag);

  [[nodiscard]] const std::string& str() const { return m_out; }

  static std::string escape(std::string_view text);

 private:
  void before_value();
  std::string m_out;
  std::vector<bool> m_first;  ///< per open container: no element written yet
  bool m_after_key = false;
};

}  // namespace fissure
