#include "formats/bundle_inspect.h"

#include <algorithm>
#include <cstdio>

#include "common/json_writer.h"
#include "formats/bundle_checks.h"
#include "formats/hdf5_io.h"

namespace fissure::formats {
namespace {

constexpr const char* kStageGroups[] = {"embedding", "walls", "collision"};

void collect_datasets(hid_t group, const std::string& prefix, std::vector<DatasetSummary>& out) {
  for (const std::string& name : h5::list_links(group)) {
    H5O_info_t info;
    if (H5Oget_info_by_name(group, name.c_str(), &info, H5P_DEFAULT) < 0) continue;
    const std::string path = prefix + "/" + name;
    if (info.type == H5O_TYPE_GROUP) {
      const h5::Handle child = h5::open_group(group, name);
      collect_datasets(child.id(), path, out);
    } else if (info.type == H5O_TYPE_DATASET) {
      DatasetSummary d;
      d.path = path;
      for (hsize_t extent : h5::dataset_shape(group, name).value_or(std::vector<hsize_t>{})) d.shape.push_back(extent);
      d.stored_bytes = h5::dataset_storage_bytes(group, name);
      out.push_back(std::move(d));
    }
  }
}

std::string human_bytes(std::uint64_t bytes) {
  char buffer[32];
  if (bytes < 1024) {
    std::snprintf(buffer, sizeof buffer, "%llu B", static_cast<unsigned long long>(bytes));
  } else if (bytes < 1024 * 1024) {
    std::snprintf(buffer, sizeof buffer, "%.1f KiB", static_cast<double>(bytes) / 1024.0);
  } else {
    std::snprintf(buffer, sizeof buffer, "%.2f MiB", static_cast<double>(bytes) / (1024.0 * 1024.0));
  }
  return buffer;
}

struct Counts {
  std::size_t boundary_faces = 0, crossing_faces = 0, inside_nodes = 0;
  std::size_t tets_by_class[3] = {0, 0, 0};
  std::vector<std::size_t> replication;
};

Counts count(const Bundle& b) {
  Counts c;
  for (FaceIndex f = 0; f < b.faces.face_count(); ++f) {
    c.boundary_faces += b.faces.is_boundary(f);
    c.crossing_faces += b.embedding.contour_offsets[f + 1] > b.embedding.contour_offsets[f];
  }
  for (const auto flag : b.embedding.node_inside) c.inside_nodes += flag;
  for (const auto cls : b.embedding.tet_class) ++c.tets_by_class[static_cast<int>(cls)];
  c.replication = replication_histogram(b.render.triangle_count(), b.embedding);
  return c;
}

}  // namespace

namespace {

BundleSummary summarize_unprobed(const std::filesystem::path& path) {
  BundleSummary s;
  s.file = path.string();
  s.bundle = read_bundle(path);
  s.file_bytes = std::filesystem::file_size(path);
  const h5::Handle file = h5::open_file_read_only(path.string());
  collect_datasets(file.id(), "", s.datasets);
  for (const char* stage : kStageGroups) {
    if (h5::has_link(file.id(), stage)) s.stages.emplace_back(stage);
  }
  return s;
}

}  // namespace

BundleSummary summarize_bundle(const std::filesystem::path& path) {
  // The listing walks links that read_bundle does not: probe the whole summary.
  h5::require_legacy_file_readable(path, [&] { (void)summarize_unprobed(path); });
  return summarize_unprobed(path);
}

std::string summary_text(const BundleSummary& s) {
  const Bundle& b = s.bundle;
  const Counts c = count(b);
  std::string out;
  // Sized per call: file names, input paths and the options' JSON can be any length (a
  // fixed 256-byte line cut the options of every real bundle short).
  auto add = [&](const char* format, auto... args) {
    const auto length = static_cast<std::size_t>(std::snprintf(nullptr, 0, format, args...));
    const std::size_t at = out.size();
    out.resize(at + length + 1);
    std::snprintf(out.data() + at, length + 1, format, args...);
    out.resize(at + length);
  };
  add("%s  (%s)\n", s.file.c_str(), human_bytes(s.file_bytes).c_str());
  add("  schema        %s %d.%d, written by %s, units %s\n", kBundleFormatName, b.metadata.schema_major,
      b.metadata.schema_minor, b.metadata.generator.c_str(), b.metadata.units.c_str());
  for (const BundleInput& input : b.metadata.inputs) {
    add("  input %-7s %s  sha256 %.16s…\n", input.role.c_str(), input.name.c_str(), input.sha256.c_str());
    if (!input.path.empty()) add("                read from %s (relative to the bundle)\n", input.path.c_str());
  }
  std::string stages;
  for (const auto& stage : s.stages) {
    if (!stages.empty()) stages += ", ";
    stages += stage;
  }
  add("  stages        %s\n", stages.c_str());
  add("  options       %s\n", b.metadata.bake_options.c_str());
  add("render\n  vertices      %zu\n  triangles     %zu%s%s\n", b.render.vertex_count(), b.render.triangle_count(),
      b.render.normals.cols() ? "  (+normals)" : "", b.render.uvs.cols() ? "  (+uvs)" : "");
  add("cage\n  nodes         %zu  (%zu inside the solid)\n", b.cage.node_count(), c.inside_nodes);
  add("  tets          %zu  (%zu crossing, %zu inside, %zu outside)\n", b.cage.tet_count(), c.tets_by_class[2],
      c.tets_by_class[1], c.tets_by_class[0]);
  add("  faces         %zu  (%zu boundary, %zu crossed by the surface)\n", b.faces.face_count(), c.boundary_faces,
      c.crossing_faces);
  add("embedding\n  instances     %zu  (%.3f per triangle)\n", b.embedding.instance_count(),
      b.render.triangle_count() ? static_cast<double>(b.embedding.instance_count()) / static_cast<double>(b.render.triangle_count()) : 0.0);
  out += "  replication   ";
  for (std::size_t k = 1; k < c.replication.size(); ++k) add("%zu%s:%zu ", k, k == 8 ? "+" : "x", c.replication[k]);
  add("\n  contours      %zu segments\n", b.embedding.segment_count());
  if (b.walls) {
    std::size_t by_class[3] = {0, 0, 0};
    for (const auto cls : b.walls->face_class) ++by_class[std::min(static_cast<int>(cls), 2)];
    add("walls\n  tiles         %zu of %u² texels (SDF range %.3g texels), depth %u², detail %u²\n", b.walls->tile_count(),
        b.walls->resolution, b.walls->sdf_range_texels, b.walls->depth_resolution, b.walls->detail_resolution);
    add("  faces         %zu crossing, %zu inside (shared material), %zu outside\n", by_class[2], by_class[1], by_class[0]);
  }
  if (b.collision) {
    double solid = 0.0;
    for (Index t = 0; t < b.cage.tet_count(); ++t) solid += b.collision->mass_fraction[t] * signed_volume(b.cage, t);
    add("collision\n  spheres       %zu (target radius %.6g)\n  solid volume  %.6g (Σ mass fraction × tet volume)\n",
        b.collision->sphere_tet.size(), b.collision->target_radius, solid);
  }
  out += "datasets\n";
  for (const DatasetSummary& d : s.datasets) {
    std::string shape;
    for (const auto extent : d.shape) {
      if (!shape.empty()) shape += "×";
      shape += std::to_string(extent);
    }
    add("  %-34s %-16s %s\n", d.path.c_str(), shape.c_str(), human_bytes(d.stored_bytes).c_str());
  }
  return out;
}

std::string summary_json(const BundleSummary& s) {
  const Bundle& b = s.bundle;
  const Counts c = count(b);
  JsonWriter j;
  j.begin_object();
  j.key("file").value(s.file).key("file_bytes").value(static_cast<std::uint64_t>(s.file_bytes));
  j.key("format").value(kBundleFormatName);
  j.key("schema_version").begin_array().value(b.metadata.schema_major).value(b.metadata.schema_minor).end_array();
  j.key("generator").value(b.metadata.generator).key("units").value(b.metadata.units);
  j.key("bake_options").value(b.metadata.bake_options);
  j.key("inputs").begin_array();
  for (const BundleInput& input : b.metadata.inputs) {
    j.begin_object().key("role").value(input.role).key("file").value(input.name).key("sha256").value(input.sha256);
    j.key("path").value(input.path).end_object();  // "" when the bake did not record it (schema < 1.2)
  }
  j.end_array();
  j.key("stages").begin_array();
  for (const auto& stage : s.stages) j.value(stage);
  j.end_array();
  j.key("counts").begin_object();
  j.key("render_vertices").value(static_cast<std::uint64_t>(b.render.vertex_count()));
  j.key("render_triangles").value(static_cast<std::uint64_t>(b.render.triangle_count()));
  j.key("cage_nodes").value(static_cast<std::uint64_t>(b.cage.node_count()));
  j.key("cage_nodes_inside").value(static_cast<std::uint64_t>(c.inside_nodes));
  j.key("cage_tets").value(static_cast<std::uint64_t>(b.cage.tet_count()));
  j.key("tets_crossing").value(static_cast<std::uint64_t>(c.tets_by_class[2]));
  j.key("tets_inside").value(static_cast<std::uint64_t>(c.tets_by_class[1]));
  j.key("tets_outside").value(static_cast<std::uint64_t>(c.tets_by_class[0]));
  j.key("cage_faces").value(static_cast<std::uint64_t>(b.faces.face_count()));
  j.key("boundary_faces").value(static_cast<std::uint64_t>(c.boundary_faces));
  j.key("crossing_faces").value(static_cast<std::uint64_t>(c.crossing_faces));
  j.key("instances").value(static_cast<std::uint64_t>(b.embedding.instance_count()));
  j.key("contour_segments").value(static_cast<std::uint64_t>(b.embedding.segment_count()));
  if (b.walls) {
    j.key("wall_tiles").value(static_cast<std::uint64_t>(b.walls->tile_count()));
    j.key("wall_resolution").value(static_cast<std::uint64_t>(b.walls->resolution));
  }
  if (b.collision) j.key("collision_spheres").value(static_cast<std::uint64_t>(b.collision->sphere_tet.size()));
  j.end_object();
  j.key("replication").begin_array();
  for (const auto n : c.replication) j.value(static_cast<std::uint64_t>(n));
  j.end_array();
  j.key("datasets").begin_array();
  for (const DatasetSummary& d : s.datasets) {
    j.begin_object().key("path").value(d.path).key("shape").begin_array();
    for (const auto extent : d.shape) j.value(extent);
    j.end_array().key("stored_bytes").value(d.stored_bytes).end_object();
  }
  j.end_array();
  j.end_object();
  return j.str() + "\n";
}

}  // namespace fissure::formats
