#include "formats/bundle.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <system_error>

#include "common/error.h"
#include "formats/hdf5_io.h"

namespace fissure::formats {
namespace {

using h5::ElementType;

// --- writing --------------------------------------------------------------------

void write_matrix(hid_t group, const std::string& name, const Matrix3Xd& m) {
  h5::write_dataset(group, name, ElementType::F64, {static_cast<hsize_t>(m.cols()), 3}, m.data());
}
void write_matrix(hid_t group, const std::string& name, const Matrix2Xd& m) {
  h5::write_dataset(group, name, ElementType::F64, {static_cast<hsize_t>(m.cols()), 2}, m.data());
}
template <int Rows>
void write_indices(hid_t group, const std::string& name, const Eigen::Matrix<Index, Rows, Eigen::Dynamic>& m) {
  h5::write_dataset(group, name, ElementType::U32, {static_cast<hsize_t>(m.cols()), Rows}, m.data());
}
template <typename T>
void write_vector(hid_t group, const std::string& name, ElementType type, const std::vector<T>& v) {
  h5::write_dataset(group, name, type, {static_cast<hsize_t>(v.size())}, v.data());
}

void write_walls(hid_t file, const Walls& w) {
  const h5::Handle group = h5::create_group(file, "walls");
  h5::write_attribute(group.id(), "resolution", std::int64_t{w.resolution});
  h5::write_attribute(group.id(), "sdf_range_texels", w.sdf_range_texels);
  h5::write_attribute(group.id(), "depth_resolution", std::int64_t{w.depth_resolution});
  h5::write_attribute(group.id(), "depth_scale", w.depth_scale);
  h5::write_attribute(group.id(), "detail_resolution", std::int64_t{w.detail_resolution});
  h5::write_attribute(group.id(), "detail_seed", static_cast<std::int64_t>(w.detail_seed));
  write_vector(group.id(), "face_class", ElementType::U8, w.face_class);
  write_vector(group.id(), "face_tile", ElementType::U32, w.face_tile);
  write_vector(group.id(), "face_inside_area", ElementType::F64, w.face_inside_area);
  // Schema 1.1 readers require it: walls made without one get no relief (all zero).
  std::vector<double> clearance = w.face_clearance;
  clearance.resize(w.face_class.size(), 0.0);
  write_vector(group.id(), "face_clearance", ElementType::F64, clearance);
  const auto tiles = static_cast<hsize_t>(w.tile_count());
  h5::write_dataset(group.id(), "sdf", ElementType::U8, {tiles, w.resolution, w.resolution}, w.sdf.data());
  h5::write_dataset(group.id(), "depth", ElementType::U8, {tiles, w.depth_resolution, w.depth_resolution}, w.depth.data());
  h5::write_dataset(group.id(), "detail_height", ElementType::U8, {w.detail_resolution, w.detail_resolution},
                    w.detail_height.data());
  h5::write_dataset(group.id(), "detail_normal", ElementType::U8, {w.detail_resolution, w.detail_resolution, 3},
                    w.detail_normal.data());
}

void write_collision(hid_t file, const Collision& c) {
  const h5::Handle group = h5::create_group(file, "collision");
  h5::write_attribute(group.id(), "target_radius", c.target_radius);
  h5::write_attribute(group.id(), "sampled_tets", static_cast<std::int64_t>(c.sampled_tets));
  write_vector(group.id(), "sphere_tet", ElementType::U32, c.sphere_tet);
  h5::write_dataset(group.id(), "sphere_barycentric", ElementType::F64, {static_cast<hsize_t>(c.sphere_tet.size()), 4},
                    c.sphere_barycentric.data());
  write_vector(group.id(), "sphere_radius", ElementType::F64, c.sphere_radius);
  write_vector(group.id(), "reserve_tet", ElementType::U32, c.reserve_tet);
  h5::write_dataset(group.id(), "reserve_barycentric", ElementType::F64, {static_cast<hsize_t>(c.reserve_tet.size()), 4},
                    c.reserve_barycentric.data());
  write_vector(group.id(), "reserve_radius", ElementType::F64, c.reserve_radius);
  write_vector(group.id(), "reserve_cover_tet", ElementType::U32, c.reserve_cover_tet);
  write_vector(group.id(), "mass_fraction", ElementType::F64, c.mass_fraction);
  h5::write_dataset(group.id(), "center_of_mass", ElementType::F64, {static_cast<hsize_t>(c.center_of_mass.size()), 4},
                    c.center_of_mass.data());
}

void write_contents(hid_t file, const Bundle& b) {
  const BundleMetadata& meta = b.metadata;
  h5::write_attribute(file, "format", std::string(kBundleFormatName));
  h5::write_attribute(file, "schema_version_major", std::int64_t{meta.schema_major});
  h5::write_attribute(file, "schema_version_minor", std::int64_t{meta.schema_minor});
  h5::write_attribute(file, "generator", meta.generator);
  h5::write_attribute(file, "units", meta.units);
  h5::write_attribute(file, "bake_options", meta.bake_options);

  {
    const h5::Handle inputs = h5::create_group(file, "inputs");
    for (const BundleInput& input : meta.inputs) {
      const h5::Handle group = h5::create_group(inputs.id(), input.role);
      h5::write_attribute(group.id(), "file", input.name);
      h5::write_attribute(group.id(), "sha256", input.sha256);
      if (!input.path.empty()) h5::write_attribute(group.id(), "path", input.path);
    }
  }
  {
    const h5::Handle render = h5::create_group(file, "render");
    write_matrix(render.id(), "positions", b.render.positions);
    write_indices<3>(render.id(), "triangles", b.render.triangles);
    if (b.render.normals.cols() > 0) write_matrix(render.id(), "normals", b.render.normals);
    if (b.render.uvs.cols() > 0) write_matrix(render.id(), "uvs", b.render.uvs);
  }
  {
    const h5::Handle cage = h5::create_group(file, "cage");
    write_matrix(cage.id(), "rest_positions", b.cage.rest_positions);
    write_indices<4>(cage.id(), "tets", b.cage.tets);
    write_indices<3>(cage.id(), "faces", b.faces.nodes);
    write_indices<2>(cage.id(), "face_tets", b.faces.tets);
    write_indices<4>(cage.id(), "tet_faces", b.faces.tet_faces);
  }
  {
    const Embedding& e = b.embedding;
    const h5::Handle group = h5::create_group(file, "embedding");
    write_vector(group.id(), "instance_triangle", ElementType::U32, e.instance_triangle);
    write_vector(group.id(), "instance_tet", ElementType::U32, e.instance_tet);
    // Eigen 4×3 column-major = per vertex, 4 coordinates: stored as [I, 3, 4].
    h5::write_dataset(group.id(), "instance_barycentric", ElementType::F64,
                      {static_cast<hsize_t>(e.instance_count()), 3, 4}, e.instance_barycentric.data());
    write_vector(group.id(), "node_winding", ElementType::F64, e.node_winding);
    write_vector(group.id(), "node_inside", ElementType::U8, e.node_inside);
    h5::write_dataset(group.id(), "tet_class", ElementType::U8, {static_cast<hsize_t>(e.tet_class.size())},
                      e.tet_class.data());
    write_vector(group.id(), "contour_offsets", ElementType::U64, e.contour_offsets);
    h5::write_dataset(group.id(), "contour_points", ElementType::F64, {static_cast<hsize_t>(e.segment_count()), 2, 3},
                      e.contour_points.data());
    write_vector(group.id(), "contour_triangle", ElementType::U32, e.contour_triangle);
    h5::write_dataset(group.id(), "contour_feature", ElementType::U8, {static_cast<hsize_t>(e.segment_count()), 2},
                      e.contour_feature.data());
    write_vector(group.id(), "face_degenerate", ElementType::U8, e.face_degenerate);
    if (e.surface_self_intersections > 0) {
      h5::write_attribute(group.id(), "surface_self_intersections", static_cast<std::int64_t>(e.surface_self_intersections));
    }
  }
  if (b.walls) write_walls(file, *b.walls);
  if (b.collision) write_collision(file, *b.collision);
}

// --- reading --------------------------------------------------------------------

class Reader {
 public:
  Reader(std::string path, hid_t file) : m_path(std::move(path)), m_file(file) {}

  h5::Handle group(const std::string& name) const {
    if (!h5::has_link(m_file, name)) {
      throw Error(m_path + ": missing group /" + name, "the file is not a complete Fissure bundle; re-bake it");
    }
    return h5::open_group(m_file, name);
  }

  /// Checks that /group/name exists with shape [rows?, trailing...]; returns rows.
  hsize_t expect_shape(hid_t group, const std::string& where, const std::string& name,
                       const std::vector<hsize_t>& trailing, std::optional<hsize_t> rows = std::nullopt) const {
    const auto shape = h5::dataset_shape(group, name);
    const std::string full = where + "/" + name;
    if (!shape) throw Error(m_path + ": missing dataset " + full, "re-bake the bundle");
    bool ok = shape->size() == trailing.size() + 1;
    for (std::size_t k = 0; ok && k < trailing.size(); ++k) ok = (*shape)[k + 1] == trailing[k];
    if (ok && rows) ok = (*shape)[0] == *rows;
    if (!ok) {
      std::string got, want = rows ? std::to_string(*rows) : std::string("N");
      for (std::size_t k = 0; k < shape->size(); ++k) {
        if (k > 0) got += ",";
        got += std::to_string((*shape)[k]);
      }
      for (hsize_t t : trailing) want += "," + std::to_string(t);
      throw Error(m_path + ": dataset " + full + " has shape [" + got + "], expected [" + want + "]");
    }
    return (*shape)[0];
  }

  Matrix3Xd read3(hid_t group, const std::string& where, const std::string& name, std::optional<hsize_t> rows = {}) const {
    Matrix3Xd m(3, static_cast<Eigen::Index>(expect_shape(group, where, name, {3}, rows)));
    h5::read_dataset(group, name, ElementType::F64, m.data());
    return m;
  }

  template <int Rows>
  Eigen::Matrix<Index, Rows, Eigen::Dynamic> read_indices(hid_t group, const std::string& where, const std::string& name,
                                                           std::size_t limit, std::optional<hsize_t> rows = {},
                                                           bool allow_invalid = false) const {
    Eigen::Matrix<Index, Rows, Eigen::Dynamic> m(Rows,
                                                 static_cast<Eigen::Index>(expect_shape(group, where, name, {Rows}, rows)));
    h5::read_dataset(group, name, ElementType::U32, m.data());
    check_range(m.data(), static_cast<std::size_t>(m.size()), Rows, limit, where + "/" + name, allow_invalid);
    return m;
  }

  template <typename T>
  std::vector<T> read_vector(hid_t group, const std::string& where, const std::string& name, ElementType type,
                             std::optional<hsize_t> rows = {}) const {
    std::vector<T> v(expect_shape(group, where, name, {}, rows));
    h5::read_dataset(group, name, type, v.data());
    return v;
  }

  void check_range(const Index* data, std::size_t count, std::size_t row_width, std::size_t limit,
                   const std::string& dataset, bool allow_invalid) const {
    for (std::size_t i = 0; i < count; ++i) {
      if (data[i] < limit || (allow_invalid && data[i] == kInvalidIndex)) continue;
      throw Error(m_path + ": " + dataset + " row " + std::to_string(i / row_width) + " holds index " +
                      std::to_string(data[i]) + ", out of range [0, " + std::to_string(limit) + ")",
                  "the bundle is corrupt; re-bake it");
    }
  }

  [[nodiscard]] const std::string& path() const { return m_path; }

 private:
  std::string m_path;
  hid_t m_file;
};

BundleMetadata read_metadata(const Reader& reader, hid_t file) {
  BundleMetadata meta;
  const auto format = h5::read_string_attribute(file, "format");
  if (!format || *format != kBundleFormatName) {
    throw Error(reader.path() + ": not a Fissure bundle (root attribute 'format' is " +
                    (format ? "'" + *format + "'" : std::string("missing")) + ")",
                "pass a file written by fissure-bake");
  }
  const auto major = h5::read_integer_attribute(file, "schema_version_major");
  const auto minor = h5::read_integer_attribute(file, "schema_version_minor");
  if (!major || !minor) throw Error(reader.path() + ": the bundle has no schema version attributes");
  if (*major > kBundleSchemaMajor) {
    throw Error(reader.path() + ": bundle schema " + std::to_string(*major) + "." + std::to_string(*minor) +
                    " is newer than this build reads (" + std::to_string(kBundleSchemaMajor) + ".x)",
                "upgrade Fissure, or re-bake the asset with this version");
  }
  if (*major < kBundleSchemaMajor) {
    throw Error(reader.path() + ": bundle schema " + std::to_string(*major) + "." + std::to_string(*minor) +
                    " is older than this build reads (" + std::to_string(kBundleSchemaMajor) + ".x)",
                "re-bake the asset with this version of fissure-bake");
  }
  meta.schema_major = static_cast<int>(*major);
  meta.schema_minor = static_cast<int>(*minor);
  meta.generator = h5::read_string_attribute(file, "generator").value_or("");
  meta.units = h5::read_string_attribute(file, "units").value_or("m");
  meta.bake_options = h5::read_string_attribute(file, "bake_options").value_or("{}");
  if (h5::has_link(file, "inputs")) {
    const h5::Handle inputs = h5::open_group(file, "inputs");
    for (const std::string& role : h5::list_links(inputs.id())) {
      const h5::Handle group = h5::open_group(inputs.id(), role);
      meta.inputs.push_back({role, h5::read_string_attribute(group.id(), "file").value_or(""),
                             h5::read_string_attribute(group.id(), "sha256").value_or(""),
                             h5::read_string_attribute(group.id(), "path").value_or("")});
    }
  }
  return meta;
}

void read_render(const Reader& reader, Bundle& b) {
  const h5::Handle g = reader.group("render");
  b.render.positions = reader.read3(g.id(), "/render", "positions");
  const auto vertices = static_cast<hsize_t>(b.render.positions.cols());
  b.render.triangles = reader.read_indices<3>(g.id(), "/render", "triangles", vertices);
  if (h5::has_link(g.id(), "normals")) b.render.normals = reader.read3(g.id(), "/render", "normals", vertices);
  if (h5::has_link(g.id(), "uvs")) {
    b.render.uvs.resize(2, static_cast<Eigen::Index>(reader.expect_shape(g.id(), "/render", "uvs", {2}, vertices)));
    h5::read_dataset(g.id(), "uvs", ElementType::F64, b.render.uvs.data());
  }
}

void read_cage(const Reader& reader, Bundle& b) {
  const h5::Handle g = reader.group("cage");
  b.cage.rest_positions = reader.read3(g.id(), "/cage", "rest_positions");
  const auto nodes = static_cast<std::size_t>(b.cage.rest_positions.cols());
  b.cage.tets = reader.read_indices<4>(g.id(), "/cage", "tets", nodes);
  const auto tets = static_cast<hsize_t>(b.cage.tets.cols());
  b.faces.nodes = reader.read_indices<3>(g.id(), "/cage", "faces", nodes);
  const auto faces = static_cast<hsize_t>(b.faces.nodes.cols());
  b.faces.tets = reader.read_indices<2>(g.id(), "/cage", "face_tets", tets, faces, true);
  b.faces.tet_faces = reader.read_indices<4>(g.id(), "/cage", "tet_faces", faces, tets);
}

void read_embedding(const Reader& reader, Bundle& b) {
  const std::string& name = reader.path();
  const h5::Handle g = reader.group("embedding");
  Embedding& e = b.embedding;
  const std::string where = "/embedding";
  e.instance_triangle = reader.read_vector<TriangleIndex>(g.id(), where, "instance_triangle", ElementType::U32);
  const hsize_t instances = e.instance_triangle.size();
  e.instance_tet = reader.read_vector<TetIndex>(g.id(), where, "instance_tet", ElementType::U32, instances);
  reader.check_range(e.instance_triangle.data(), instances, 1, b.render.triangle_count(), where + "/instance_triangle", false);
  reader.check_range(e.instance_tet.data(), instances, 1, b.cage.tet_count(), where + "/instance_tet", false);
  reader.expect_shape(g.id(), where, "instance_barycentric", {3, 4}, instances);
  e.instance_barycentric.resize(instances);
  h5::read_dataset(g.id(), "instance_barycentric", ElementType::F64, e.instance_barycentric.data());

  const auto nodes = static_cast<hsize_t>(b.cage.node_count());
  e.node_winding = reader.read_vector<double>(g.id(), where, "node_winding", ElementType::F64, nodes);
  e.node_inside = reader.read_vector<std::uint8_t>(g.id(), where, "node_inside", ElementType::U8, nodes);
  const auto classes = reader.read_vector<std::uint8_t>(g.id(), where, "tet_class", ElementType::U8,
                                                        static_cast<hsize_t>(b.cage.tet_count()));
  for (std::size_t t = 0; t < classes.size(); ++t) {
    if (classes[t] > 2) throw Error(name + ": " + where + "/tet_class row " + std::to_string(t) + " holds " +
                                    std::to_string(classes[t]) + "; valid classes are 0, 1, 2");
    e.tet_class.push_back(static_cast<TetClass>(classes[t]));
  }

  const auto faces = static_cast<hsize_t>(b.faces.face_count());
  e.contour_offsets = reader.read_vector<std::uint64_t>(g.id(), where, "contour_offsets", ElementType::U64, faces + 1);
  e.contour_triangle = reader.read_vector<TriangleIndex>(g.id(), where, "contour_triangle", ElementType::U32);
  const hsize_t segments = e.contour_triangle.size();
  reader.check_range(e.contour_triangle.data(), segments, 1, b.render.triangle_count(), where + "/contour_triangle", false);
  for (std::size_t f = 0; f < faces; ++f) {
    if (e.contour_offsets[f] > e.contour_offsets[f + 1]) {
      throw Error(name + ": " + where + "/contour_offsets decreases at face " + std::to_string(f));
    }
  }
  if (e.contour_offsets.front() != 0 || e.contour_offsets.back() != segments) {
    throw Error(name + ": " + where + "/contour_offsets does not span the " + std::to_string(segments) + " segments");
  }
  reader.expect_shape(g.id(), where, "contour_points", {2, 3}, segments);
  e.contour_points.resize(segments);
  h5::read_dataset(g.id(), "contour_points", ElementType::F64, e.contour_points.data());
  e.face_degenerate = reader.read_vector<std::uint8_t>(g.id(), where, "face_degenerate", ElementType::U8, faces);
  e.surface_self_intersections = static_cast<std::uint64_t>(
      std::max<std::int64_t>(0, h5::read_integer_attribute(g.id(), "surface_self_intersections").value_or(0)));
  reader.expect_shape(g.id(), where, "contour_feature", {2}, segments);
  e.contour_feature.resize(segments);
  h5::read_dataset(g.id(), "contour_feature", ElementType::U8, e.contour_feature.data());
  for (std::size_t s = 0; s < segments; ++s) {
    for (const std::uint8_t f : e.contour_feature[s]) {
      if (f > 5 && f != kContourInterior) {
        throw Error(name + ": " + where + "/contour_feature row " + std::to_string(s) + " holds " + std::to_string(f) +
                    "; valid values are 0–5 and 255");
      }
    }
  }
}

Walls read_walls(const Reader& reader, const Bundle& b) {
  const std::string& name = reader.path();
  const h5::Handle g = reader.group("walls");
  const std::string where = "/walls";
  Walls w;
  auto integer = [&](const char* key, std::int64_t lo, std::int64_t hi) {
    const auto value = h5::read_integer_attribute(g.id(), key);
    if (!value || *value < lo || *value > hi) {
      throw Error(name + ": " + where + " lacks a valid '" + key + "' attribute (an integer in " + std::to_string(lo) +
                  " … " + std::to_string(hi) + ")");
    }
    return *value;
  };
  auto real = [&](const char* key) {
    const auto value = h5::read_double_attribute(g.id(), key);
    if (!value || !(*value > 0) || !std::isfinite(*value)) {
      throw Error(name + ": " + where + " lacks a valid '" + key + "' attribute (a positive number)");
    }
    return *value;
  };
  w.resolution = static_cast<std::uint32_t>(integer("resolution", 1, 4096));
  w.sdf_range_texels = real("sdf_range_texels");
  w.depth_resolution = static_cast<std::uint32_t>(integer("depth_resolution", 1, 4096));
  w.depth_scale = real("depth_scale");
  w.detail_resolution = static_cast<std::uint32_t>(integer("detail_resolution", 1, 8192));
  // The seed is a uint64 stored in an int64 attribute bit for bit.
  w.detail_seed = static_cast<std::uint64_t>(integer("detail_seed", std::numeric_limits<std::int64_t>::min(),
                                                     std::numeric_limits<std::int64_t>::max()));
  const auto faces = static_cast<hsize_t>(b.faces.face_count());
  const auto face_classes = reader.read_vector<std::uint8_t>(g.id(), where, "face_class", ElementType::U8, faces);
  for (std::size_t f = 0; f < face_classes.size(); ++f) {
    if (face_classes[f] > 3) throw Error(name + ": " + where + "/face_class row " + std::to_string(f) + " holds " +
                                         std::to_string(face_classes[f]) + "; valid classes are 0, 1, 2, 3");
    w.face_class.push_back(static_cast<FaceClass>(face_classes[f]));
  }
  w.face_tile = reader.read_vector<Index>(g.id(), where, "face_tile", ElementType::U32, faces);
  w.face_inside_area = reader.read_vector<double>(g.id(), where, "face_inside_area", ElementType::F64, faces);
  if (b.metadata.schema_minor >= 1 || h5::has_link(g.id(), "face_clearance")) {  // schema 1.1
    w.face_clearance = reader.read_vector<double>(g.id(), where, "face_clearance", ElementType::F64, faces);
  }
  const hsize_t tiles = reader.expect_shape(g.id(), where, "sdf", {w.resolution, w.resolution});
  reader.check_range(w.face_tile.data(), w.face_tile.size(), 1, tiles, where + "/face_tile", true);
  w.sdf.resize(tiles * w.resolution * w.resolution);
  h5::read_dataset(g.id(), "sdf", ElementType::U8, w.sdf.data());
  reader.expect_shape(g.id(), where, "depth", {w.depth_resolution, w.depth_resolution}, tiles);
  w.depth.resize(tiles * w.depth_resolution * w.depth_resolution);
  h5::read_dataset(g.id(), "depth", ElementType::U8, w.depth.data());
  reader.expect_shape(g.id(), where, "detail_height", {w.detail_resolution}, w.detail_resolution);
  w.detail_height.resize(static_cast<std::size_t>(w.detail_resolution) * w.detail_resolution);
  h5::read_dataset(g.id(), "detail_height", ElementType::U8, w.detail_height.data());
  reader.expect_shape(g.id(), where, "detail_normal", {w.detail_resolution, 3}, w.detail_resolution);
  w.detail_normal.resize(w.detail_height.size() * 3);
  h5::read_dataset(g.id(), "detail_normal", ElementType::U8, w.detail_normal.data());
  return w;
}

/// A set of spheres: `prefix`_tet (each a tet of `tet_count`), `prefix`_barycentric and
/// `prefix`_radius, as many.
void read_spheres(const Reader& reader, hid_t group, const std::string& where, const std::string& prefix,
                  std::size_t tet_count, std::vector<TetIndex>& tet, std::vector<Vec4>& barycentric,
                  std::vector<double>& radius) {
  tet = reader.read_vector<TetIndex>(group, where, prefix + "_tet", ElementType::U32);
  const hsize_t count = tet.size();
  reader.check_range(tet.data(), count, 1, tet_count, where + "/" + prefix + "_tet", false);
  reader.expect_shape(group, where, prefix + "_barycentric", {4}, count);
  barycentric.resize(count);
  h5::read_dataset(group, prefix + "_barycentric", ElementType::F64, barycentric.data());
  radius = reader.read_vector<double>(group, where, prefix + "_radius", ElementType::F64, count);
}

Collision read_collision(const Reader& reader, const Bundle& b) {
  const h5::Handle g = reader.group("collision");
  const std::string where = "/collision";
  Collision c;
  c.target_radius = h5::read_double_attribute(g.id(), "target_radius").value_or(0.0);
  c.sampled_tets = static_cast<std::uint64_t>(std::max<std::int64_t>(0, h5::read_integer_attribute(g.id(), "sampled_tets").value_or(0)));

  read_spheres(reader, g.id(), where, "sphere", b.cage.tet_count(), c.sphere_tet, c.sphere_barycentric, c.sphere_radius);
  if (h5::has_link(g.id(), "reserve_tet")) {  // bundles from sphere_version 3 on
    read_spheres(reader, g.id(), where, "reserve", b.cage.tet_count(), c.reserve_tet, c.reserve_barycentric,
                 c.reserve_radius);
    const hsize_t reserves = c.reserve_tet.size();
    c.reserve_cover_tet = reader.read_vector<TetIndex>(g.id(), where, "reserve_cover_tet", ElementType::U32, reserves);
    reader.check_range(c.reserve_cover_tet.data(), reserves, 1, b.cage.tet_count(), where + "/reserve_cover_tet", true);
  }
  const auto tets = static_cast<hsize_t>(b.cage.tet_count());
  c.mass_fraction = reader.read_vector<double>(g.id(), where, "mass_fraction", ElementType::F64, tets);
  reader.expect_shape(g.id(), where, "center_of_mass", {4}, tets);
  c.center_of_mass.resize(tets);
  h5::read_dataset(g.id(), "center_of_mass", ElementType::F64, c.center_of_mass.data());
  return c;
}

}  // namespace

void write_bundle(const std::filesystem::path& path, const Bundle& bundle) {
  h5::write_file_atomically(path, [&](hid_t file) { write_contents(file, bundle); });
}

Bundle read_bundle_unchecked_context(const std::filesystem::path& path);

Bundle read_bundle(const std::filesystem::path& path) {
  h5::require_legacy_file_readable(path, [&] { (void)read_bundle_unchecked_context(path); });
  try {
    return read_bundle_unchecked_context(path);
  } catch (const Error& e) {
    // Low-level HDF5 failures do not know the file; name it here.
    if (std::string_view(e.what()).rfind("HDF5:", 0) == 0) throw Error(path.string() + ": " + e.what(), e.hint());
    throw;
  }
}

Bundle read_bundle_unchecked_context(const std::filesystem::path& path) {
  const std::string name = path.string();
  {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) throw Error(name + ": file not found");
  }
  const h5::Handle file = h5::open_file_read_only(name);
  const Reader reader(name, file.id());
  Bundle b;
  b.metadata = read_metadata(reader, file.id());
  read_render(reader, b);
  read_cage(reader, b);
  read_embedding(reader, b);
  if (h5::has_link(file.id(), "walls")) b.walls = read_walls(reader, b);
  if (h5::has_link(file.id(), "collision")) b.collision = read_collision(reader, b);
  return b;
}

}  // namespace fissure::formats
