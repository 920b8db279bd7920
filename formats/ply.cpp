#include "formats/ply.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>
#include <vector>

#include "common/error.h"
#include "common/input_file.h"

namespace fissure::formats {
namespace {

constexpr std::size_t kMaxHeaderBytes = 1 << 20;
constexpr std::uint64_t kMaxCount = std::uint64_t{kInvalidIndex} - 1;
const char* const kHint = "check that the file is complete and was exported as PLY 1.0";

enum class Encoding { Ascii, LittleEndian, BigEndian };
enum class Scalar { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

std::optional<Scalar> parse_scalar(std::string_view name) {
  static constexpr std::array<std::pair<std::string_view, Scalar>, 16> kNames{{
      {"char", Scalar::Int8},     {"int8", Scalar::Int8},       {"uchar", Scalar::UInt8},    {"uint8", Scalar::UInt8},
      {"short", Scalar::Int16},   {"int16", Scalar::Int16},     {"ushort", Scalar::UInt16},  {"uint16", Scalar::UInt16},
      {"int", Scalar::Int32},     {"int32", Scalar::Int32},     {"uint", Scalar::UInt32},    {"uint32", Scalar::UInt32},
      {"float", Scalar::Float32}, {"float32", Scalar::Float32}, {"double", Scalar::Float64}, {"float64", Scalar::Float64},
  }};
  for (const auto& [text, scalar] : kNames) {
    if (text == name) return scalar;
  }
  return std::nullopt;
}

std::size_t scalar_bytes(Scalar s) {
  switch (s) {
    case Scalar::Int8: case Scalar::UInt8: return 1;
    case Scalar::Int16: case Scalar::UInt16: return 2;
    case Scalar::Int32: case Scalar::UInt32: case Scalar::Float32: return 4;
    case Scalar::Float64: return 8;
  }
  return 1;
}

struct Property {
  std::string name;
  Scalar type = Scalar::Float32;
  std::optional<Scalar> list_count;  ///< set for list properties
};

struct Element {
  std::string name;
  std::uint64_t count = 0;
  std::vector<Property> properties;
  std::size_t header_line = 0;

  [[nodiscard]] int find(std::initializer_list<std::string_view> names) const {
    for (std::size_t p = 0; p < properties.size(); ++p) {
      for (const auto name : names) {
        if (properties[p].name == name && !properties[p].list_count) return static_cast<int>(p);
      }
    }
    return -1;
  }
  /// Fewest bytes one element takes: every scalar, every list's count and no items;
  /// in ascii, one character and a separator per value.
  [[nodiscard]] std::size_t min_bytes(Encoding encoding) const {
    std::size_t bytes = 0;
    for (const Property& p : properties) bytes += encoding == Encoding::Ascii ? 2 : scalar_bytes(p.list_count.value_or(p.type));
    return bytes;
  }
};

struct Header {
  Encoding encoding = Encoding::Ascii;
  std::vector<Element> elements;
  std::size_t body_offset = 0;
  std::size_t body_line = 0;
};

/// A value as the file wrote it, even where it fits no integer type.
std::string number_text(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", value);
  return text;
}

std::vector<std::string_view> words(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    const std::size_t start = i;
    while (i < line.size() && !std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    if (i > start) out.push_back(line.substr(start, i - start));
  }
  return out;
}

class HeaderParser {
 public:
  HeaderParser(std::string_view bytes, const std::string& name) : m_bytes(bytes), m_name(name) {}

  Header parse() {
    if (m_bytes.substr(0, 4) != "ply\n" && m_bytes.substr(0, 5) != "ply\r\n") {
      throw Error(m_name + ": not a PLY file (it does not start with the line 'ply')", kHint);
    }
    Header header;
    bool has_format = false;
    for (std::size_t line = 1;; ++line) {
      const std::size_t end = m_bytes.find('\n', m_offset);
      if (end == std::string_view::npos || end > kMaxHeaderBytes) {
        throw Error(m_name + ": the header has no 'end_header' line" +
                        (end == std::string_view::npos ? std::string() : " in its first 1 MiB"),
                    kHint);
      }
      const auto w = words(m_bytes.substr(m_offset, end - m_offset));
      m_offset = end + 1;
      if (line == 1 || w.empty() || w[0] == "comment" || w[0] == "obj_info") continue;
      const std::string where = m_name + ":" + std::to_string(line);
      if (w[0] == "end_header") break;
      if (w[0] == "format") {
        header.encoding = parse_format(w, where);
        has_format = true;
      } else if (w[0] == "element") {
        header.elements.push_back(parse_element(w, where, line));
      } else if (w[0] == "property") {
        if (header.elements.empty()) throw Error(where + ": a property before any element", kHint);
        header.elements.back().properties.push_back(parse_property(w, where));
      } else {
        throw Error(where + ": unknown header line " + quote_from_file(w[0]),
                    "a PLY header holds format, element, property, comment and obj_info lines");
      }
      header.body_line = line + 1;
    }
    if (!has_format) throw Error(m_name + ": the header has no 'format' line", kHint);
    header.body_offset = m_offset;
    return header;
  }

 private:
  static Encoding parse_format(const std::vector<std::string_view>& w, const std::string& where) {
    if (w.size() != 3 || w[2] != "1.0") throw Error(where + ": expected 'format <encoding> 1.0'", kHint);
    if (w[1] == "ascii") return Encoding::Ascii;
    if (w[1] == "binary_little_endian") return Encoding::LittleEndian;
    if (w[1] == "binary_big_endian") return Encoding::BigEndian;
    throw Error(where + ": unknown encoding " + quote_from_file(w[1]),
                "PLY encodings are ascii, binary_little_endian and binary_big_endian");
  }

  static Element parse_element(const std::vector<std::string_view>& w, const std::string& where, std::size_t line) {
    std::uint64_t count = 0;
    if (w.size() != 3 || std::from_chars(w[2].data(), w[2].data() + w[2].size(), count).ec != std::errc() ||
        count > kMaxCount) {
      throw Error(where + ": expected 'element <name> <count>' with a count below 2^32-1", kHint);
    }
    return Element{std::string(w[1]), count, {}, line};
  }

  static Property parse_property(const std::vector<std::string_view>& w, const std::string& where) {
    const auto bad_type = [&](std::string_view type) {
      return Error(where + ": unknown property type " + quote_from_file(type),
                   "PLY types are char, uchar, short, ushort, int, uint, float, double (or int8 … float64)");
    };
    if (w.size() == 3) {
      const auto type = parse_scalar(w[1]);
      if (!type) throw bad_type(w[1]);
      return Property{std::string(w[2]), *type, std::nullopt};
    }
    if (w.size() == 5 && w[1] == "list") {
      const auto count = parse_scalar(w[2]), item = parse_scalar(w[3]);
      if (!count) throw bad_type(w[2]);
      if (!item) throw bad_type(w[3]);
      if (*count == Scalar::Float32 || *count == Scalar::Float64) {
        throw Error(where + ": a list's count must be an integer type", kHint);
      }
      return Property{std::string(w[4]), *item, count};
    }
    throw Error(where + ": expected 'property <type> <name>' or 'property list <count type> <item type> <name>'", kHint);
  }

  std::string_view m_bytes;
  const std::string& m_name;
  std::size_t m_offset = 0;
};

/// Reads scalars from the body, ascii or binary, never past its end.
class BodyReader {
 public:
  BodyReader(std::string_view body, Encoding encoding, std::size_t first_line, const std::string& name)
      : m_body(body), m_encoding(encoding), m_line(first_line), m_name(name) {}

  [[nodiscard]] std::size_t remaining() const { return m_body.size() - m_offset; }

  double scalar(Scalar type, const std::string& what) {
    return m_encoding == Encoding::Ascii ? ascii_value(type, what) : binary_value(type, what);
  }

  /// A list's item count, checked against the bytes left so a corrupt count is an
  /// error, not an allocation.
  std::size_t list_count(Scalar type, Scalar item, const std::string& what) {
    const double value = scalar(type, what);
    const std::size_t per_item = m_encoding == Encoding::Ascii ? 2 : scalar_bytes(item);
    if (!(value >= 0) || value > static_cast<double>(remaining() / per_item + 1)) {
      throw Error(location() + ": " + what + " claims a list of " + number_text(value) +
                      " items, more than the file holds",
                  kHint);
    }
    return static_cast<std::size_t>(value);
  }

  [[nodiscard]] std::string location() const {
    return m_encoding == Encoding::Ascii ? m_name + ":" + std::to_string(m_line) : m_name;
  }

 private:
  double ascii_value(Scalar type, const std::string& what) {
    while (m_offset < m_body.size() && std::isspace(static_cast<unsigned char>(m_body[m_offset]))) {
      if (m_body[m_offset] == '\n') ++m_line;
      ++m_offset;
    }
    std::size_t end = m_offset;
    while (end < m_body.size() && !std::isspace(static_cast<unsigned char>(m_body[end]))) ++end;
    if (end == m_offset) throw Error(location() + ": the file ends before " + what, kHint);
    const char* first = m_body.data() + m_offset;
    const char* last = m_body.data() + end;
    double value = 0.0;
    const auto result = std::from_chars(first, last, value);
    if (result.ec != std::errc() || result.ptr != last) {
      throw Error(location() + ": " + quote_from_file({first, static_cast<std::size_t>(last - first)}) + " is not a number (" + what + ")", kHint);
    }
    if (type != Scalar::Float32 && type != Scalar::Float64 && value != std::floor(value)) {
      throw Error(location() + ": " + what + " is " + quote_from_file({first, static_cast<std::size_t>(last - first)}) + ", not an integer", kHint);
    }
    m_offset = end;
    return value;
  }

  double binary_value(Scalar type, const std::string& what) {
    const std::size_t size = scalar_bytes(type);
    if (remaining() < size) throw Error(m_name + ": the file ends before " + what, kHint);
    std::array<unsigned char, 8> raw{};
    std::memcpy(raw.data(), m_body.data() + m_offset, size);
    m_offset += size;
    const bool swap = (m_encoding == Encoding::BigEndian) == (std::endian::native == std::endian::little);
    if (swap) std::reverse(raw.begin(), raw.begin() + static_cast<std::ptrdiff_t>(size));
    switch (type) {
      case Scalar::Int8: return static_cast<std::int8_t>(raw[0]);
      case Scalar::UInt8: return raw[0];
      case Scalar::Int16: return as<std::int16_t>(raw);
      case Scalar::UInt16: return as<std::uint16_t>(raw);
      case Scalar::Int32: return as<std::int32_t>(raw);
      case Scalar::UInt32: return as<std::uint32_t>(raw);
      case Scalar::Float32: return as<float>(raw);
      case Scalar::Float64: return as<double>(raw);
    }
    return 0.0;
  }

  template <typename T>
  static double as(const std::array<unsigned char, 8>& raw) {
    T value;
    std::memcpy(&value, raw.data(), sizeof(T));
    return static_cast<double>(value);
  }

  std::string_view m_body;
  Encoding m_encoding;
  std::size_t m_offset = 0;
  std::size_t m_line;
  const std::string& m_name;
};

/// Which vertex properties feed the mesh.
struct VertexLayout {
  int position[3];
  int normal[3];
  int uv[2];

  explicit VertexLayout(const Element& e)
      : position{e.find({"x"}), e.find({"y"}), e.find({"z"})},
        normal{e.find({"nx"}), e.find({"ny"}), e.find({"nz"})},
        uv{e.find({"u", "s", "texture_u"}), e.find({"v", "t", "texture_v"})} {}
  [[nodiscard]] bool has_normals() const { return normal[0] >= 0 && normal[1] >= 0 && normal[2] >= 0; }
  [[nodiscard]] bool has_uvs() const { return uv[0] >= 0 && uv[1] >= 0; }
};

class BodyParser {
 public:
  BodyParser(const Header& header, BodyReader& reader, const std::string& name)
      : m_header(header), m_reader(reader), m_name(name) {}

  PlyMesh parse() {
    const Element* vertex = nullptr;
    const Element* face = nullptr;
    for (const Element& e : m_header.elements) {
      if (e.name == "vertex" && vertex == nullptr) vertex = &e;
      if (e.name == "face" && face == nullptr) face = &e;
    }
    require_elements(vertex, face);
    for (const Element& e : m_header.elements) {
      require_fits(e);
      if (&e == vertex) {
        read_vertices(e);
      } else if (&e == face) {
        read_faces(e);
      } else {
        skip(e);
      }
    }
    check_indices();
    m_result.mesh.triangles.resize(3, static_cast<Eigen::Index>(m_corners.size() / 3));
    std::copy(m_corners.begin(), m_corners.end(), m_result.mesh.triangles.data());
    return std::move(m_result);
  }

 private:
  void require_elements(const Element* vertex, const Element* face) const {
    if (vertex == nullptr || VertexLayout(*vertex).position[2] < 0 || VertexLayout(*vertex).position[0] < 0 ||
        VertexLayout(*vertex).position[1] < 0) {
      throw Error(m_name + ": no 'vertex' element with x, y and z properties", "export the mesh's vertex positions");
    }
    if (face == nullptr || face_list(*face) < 0) {
      throw Error(m_name + ": no 'face' element with a vertex_indices list", "export the surface as polygons, not points");
    }
  }

  static int face_list(const Element& e) {
    for (std::size_t p = 0; p < e.properties.size(); ++p) {
      const Property& property = e.properties[p];
      if (property.list_count && (property.name == "vertex_indices" || property.name == "vertex_index")) {
        return static_cast<int>(p);
      }
    }
    return -1;
  }

  /// A count the rest of the file cannot hold is an error before any allocation.
  void require_fits(const Element& e) const {
    const std::size_t per_element = std::max<std::size_t>(e.min_bytes(m_header.encoding), 1);
    if (e.count > m_reader.remaining() / per_element + 1) {
      throw Error(m_name + ":" + std::to_string(e.header_line) + ": element '" + e.name + "' claims " +
                      std::to_string(e.count) + " entries, more than the " + std::to_string(m_reader.remaining()) +
                      " bytes left can hold",
                  kHint);
    }
  }

  void read_vertices(const Element& e) {
    const VertexLayout layout(e);
    SurfaceMesh& mesh = m_result.mesh;
    const auto n = static_cast<Eigen::Index>(e.count);
    mesh.positions.resize(3, n);
    if (layout.has_normals()) mesh.normals.resize(3, n);
    if (layout.has_uvs()) mesh.uvs.resize(2, n);
    std::vector<double> values(e.properties.size());
    for (Eigen::Index v = 0; v < n; ++v) {
      read_element(e, v, values);
      for (int k = 0; k < 3; ++k) mesh.positions(k, v) = values[static_cast<std::size_t>(layout.position[k])];
      if (!mesh.positions.col(v).allFinite()) {
        throw Error(m_reader.location() + ": vertex " + std::to_string(v) + " has a non-finite coordinate",
                    "fix the exporter; such a vertex cannot be embedded");
      }
      if (layout.has_normals()) {
        for (int k = 0; k < 3; ++k) mesh.normals(k, v) = values[static_cast<std::size_t>(layout.normal[k])];
      }
      if (layout.has_uvs()) {
        for (int k = 0; k < 2; ++k) mesh.uvs(k, v) = values[static_cast<std::size_t>(layout.uv[k])];
      }
    }
    if (mesh.normals.cols() > 0) {
      mesh.normals.colwise().normalize();
      if (!mesh.normals.allFinite()) mesh.normals.resize(3, 0);  // the player computes them
    }
  }

  /// Reads one element's scalar properties into `values`; lists are skipped.
  void read_element(const Element& e, Eigen::Index index, std::vector<double>& values) {
    for (std::size_t p = 0; p < e.properties.size(); ++p) {
      const Property& property = e.properties[p];
      const std::string what = property_name(e, index, property);
      if (property.list_count) {
        const std::size_t items = m_reader.list_count(*property.list_count, property.type, what);
        for (std::size_t i = 0; i < items; ++i) m_reader.scalar(property.type, what);
      } else {
        values[p] = m_reader.scalar(property.type, what);
      }
    }
  }

  void read_faces(const Element& e) {
    const auto list = static_cast<std::size_t>(face_list(e));
    std::vector<Index> polygon;
    for (std::uint64_t f = 0; f < e.count; ++f) {
      for (std::size_t p = 0; p < e.properties.size(); ++p) {
        const Property& property = e.properties[p];
        const std::string what = property_name(e, static_cast<Eigen::Index>(f), property);
        if (!property.list_count) {
          m_reader.scalar(property.type, what);
          continue;
        }
        const std::size_t items = m_reader.list_count(*property.list_count, property.type, what);
        polygon.clear();
        for (std::size_t i = 0; i < items; ++i) {
          const double value = m_reader.scalar(property.type, what);
          if (p == list) polygon.push_back(vertex_index(value, f));
        }
        if (p == list) add_fan(polygon);
      }
    }
  }

  Index vertex_index(double value, std::uint64_t face) {
    if (!(value >= 0) || value >= static_cast<double>(kInvalidIndex)) {
      throw Error(m_reader.location() + ": face " + std::to_string(face) + " holds the vertex index " + number_text(value),
                  kHint);
    }
    // Checked at the end: the vertex element may come after the faces.
    const auto index = static_cast<Index>(value);
    if (index >= m_max_index) {
      m_max_index = index;
      m_max_face = face;
    }
    return index;
  }

  void add_fan(const std::vector<Index>& polygon) {
    if (polygon.size() < 3) {
      ++m_result.skipped_faces;
      return;
    }
    for (std::size_t k = 1; k + 1 < polygon.size(); ++k) {
      m_corners.insert(m_corners.end(), {polygon[0], polygon[k], polygon[k + 1]});
    }
  }

  void skip(const Element& e) {
    std::vector<double> values(e.properties.size());
    for (std::uint64_t i = 0; i < e.count; ++i) read_element(e, static_cast<Eigen::Index>(i), values);
  }

  void check_indices() const {
    const std::size_t vertices = m_result.mesh.vertex_count();
    if (!m_corners.empty() && m_max_index >= vertices) {
      throw Error(m_name + ": face " + std::to_string(m_max_face) + " references vertex " + std::to_string(m_max_index) +
                      " but the file has " + std::to_string(vertices) + " vertices",
                  "the file is corrupt; re-export it");
    }
  }

  static std::string property_name(const Element& e, Eigen::Index index, const Property& p) {
    return "property '" + p.name + "' of " + e.name + " " + std::to_string(index);
  }

  const Header& m_header;
  BodyReader& m_reader;
  const std::string& m_name;
  PlyMesh m_result;
  std::vector<Index> m_corners;
  Index m_max_index = 0;
  std::uint64_t m_max_face = 0;
};

}  // namespace

PlyMesh parse_ply(std::string_view bytes, const std::string& name) {
  const Header header = HeaderParser(bytes, name).parse();
  BodyReader reader(bytes.substr(header.body_offset), header.encoding, header.body_line, name);
  return BodyParser(header, reader, name).parse();
}

PlyMesh read_ply(const std::filesystem::path& path) {
  return parse_ply(read_input_file(path), path.string());
}

}  // namespace fissure::formats
