#include "formats/trajectory.h"

#include <algorithm>
#include <limits>

#include "common/error.h"
#include "formats/hdf5_io.h"

namespace fissure::formats {

namespace {

using h5::ElementType;

template <typename T>
std::vector<T> column(const auto& records, auto member) {
  std::vector<T> out;
  out.reserve(records.size());
  for (const auto& r : records) out.push_back(static_cast<T>(r.*member));
  return out;
}

/// Frames of 3×N matrices (N may grow) as one [F, N, 3] array, NaN where a column did not exist yet.
std::vector<double> pad_frames(const std::vector<Matrix3Xd>& frames, std::size_t columns) {
  std::vector<double> out(frames.size() * columns * 3, std::numeric_limits<double>::quiet_NaN());
  for (std::size_t f = 0; f < frames.size(); ++f) {
    const Matrix3Xd& x = frames[f];
    std::copy(x.data(), x.data() + x.size(), out.begin() + static_cast<std::ptrdiff_t>(f * columns * 3));
  }
  return out;
}

void write_bodies(hid_t file, const Trajectory& t) {
  const hsize_t frames = t.time.size();
  const h5::Handle bodies = h5::create_group(file, "bodies");
  for (std::size_t b = 0; b < t.bodies.size(); ++b) {
    const TrajectoryBody& body = t.bodies[b];
    const h5::Handle group = h5::create_group(bodies.id(), std::to_string(b));
    h5::write_attribute(group.id(), "name", body.name);
    const std::size_t nodes = body.split_from.size();
    h5::write_dataset(group.id(), "positions", ElementType::F64, {frames, nodes, 3}, pad_frames(body.frames, nodes).data());
    h5::write_dataset(group.id(), "split_from", ElementType::U32, {nodes}, body.split_from.data());
  }
  const h5::Handle projectiles = h5::create_group(file, "projectiles");
  const std::size_t count = t.projectiles.empty() ? 0 : static_cast<std::size_t>(t.projectiles.back().cols());
  h5::write_dataset(projectiles.id(), "positions", ElementType::F64, {frames, count, 3},
                    pad_frames(t.projectiles, count).data());
}

void write_splits(hid_t events, const std::vector<TrajectorySplit>& splits) {
  const h5::Handle group = h5::create_group(events, "splits");
  const hid_t g = group.id();
  const hsize_t s = splits.size();
  h5::write_dataset(g, "step", ElementType::U64, {s}, column<std::uint64_t>(splits, &TrajectorySplit::step).data());
  h5::write_dataset(g, "time", ElementType::F64, {s}, column<double>(splits, &TrajectorySplit::time).data());
  h5::write_dataset(g, "body", ElementType::U32, {s}, column<Index>(splits, &TrajectorySplit::body).data());
  h5::write_dataset(g, "node", ElementType::U32, {s}, column<Index>(splits, &TrajectorySplit::node).data());
  h5::write_dataset(g, "added", ElementType::U32, {s}, column<Index>(splits, &TrajectorySplit::added).data());
  h5::write_dataset(g, "eigenvalue", ElementType::F64, {s}, column<double>(splits, &TrajectorySplit::eigenvalue).data());
  std::vector<double> normals;
  std::vector<std::uint64_t> offsets{0};
  std::vector<TetIndex> moved;
  for (const TrajectorySplit& split : splits) {
    normals.insert(normals.end(), split.normal.data(), split.normal.data() + 3);
    moved.insert(moved.end(), split.moved.begin(), split.moved.end());
    offsets.push_back(moved.size());
  }
  h5::write_dataset(g, "normal", ElementType::F64, {s, 3}, normals.data());
  h5::write_dataset(g, "moved_offsets", ElementType::U64, {s + 1}, offsets.data());
  h5::write_dataset(g, "moved_tets", ElementType::U32, {moved.size()}, moved.data());
}

void write_contents(hid_t file, const Trajectory& t) {
  h5::write_attribute(file, "format", std::string("fissure-trajectory"));
  h5::write_attribute(file, "version", kTrajectoryVersion);
  h5::write_attribute(file, "scene", t.scene);
  const hsize_t frames = t.time.size();
  h5::write_dataset(file, "time", ElementType::F64, {frames}, t.time.data());
  h5::write_dataset(file, "step", ElementType::U64, {frames}, t.step.data());
  write_bodies(file, t);
  const h5::Handle events = h5::create_group(file, "events");
  write_splits(events.id(), t.splits);
  const h5::Handle exposed = h5::create_group(events.id(), "exposed_faces");
  const hsize_t e = t.exposed_faces.size();
  using Face = TrajectoryExposedFace;
  h5::write_dataset(exposed.id(), "step", ElementType::U64, {e}, column<std::uint64_t>(t.exposed_faces, &Face::step).data());
  h5::write_dataset(exposed.id(), "body", ElementType::U32, {e}, column<Index>(t.exposed_faces, &Face::body).data());
  h5::write_dataset(exposed.id(), "tet", ElementType::U32, {e}, column<Index>(t.exposed_faces, &Face::tet).data());
  h5::write_dataset(exposed.id(), "face", ElementType::U8, {e}, column<std::uint8_t>(t.exposed_faces, &Face::face).data());
}

/// Deflate cannot shrink data by more than about 1032:1, so a dataset whose shape claims
/// more than this many times its stored bytes is corrupt: checked before allocating.
constexpr std::uint64_t kMaxCompression = 1100;

class Reader {
 public:
  Reader(std::string path, hid_t file) : m_path(std::move(path)), m_file(file) {}

  [[noreturn]] void fail(const std::string& what, const std::string& hint = "record the run again") const {
    throw Error(m_path + ": " + what, hint);
  }

  h5::Handle group(hid_t parent, const std::string& name, const std::string& where) const {
    if (!h5::has_link(parent, name)) fail("missing group " + where);
    return h5::open_group(parent, name);
  }

  /// The shape of `where` (rank `trailing.size() + 1`, trailing dimensions as given; 0 in
  /// `trailing`: any), checked against the bytes the file holds for it.
  hsize_t rows(hid_t group, const std::string& name, const std::string& where, std::vector<hsize_t> trailing = {},
               std::size_t element_bytes = 8) const {
    const auto shape = h5::dataset_shape(group, name);
    if (!shape) fail("missing dataset " + where);
    if (shape->size() != trailing.size() + 1) fail("dataset " + where + " has rank " + std::to_string(shape->size()));
    std::uint64_t elements = 1;
    for (std::size_t k = 0; k < shape->size(); ++k) {
      const hsize_t d = (*shape)[k];
      if (k > 0 && trailing[k - 1] != 0 && d != trailing[k - 1]) fail("dataset " + where + " has the wrong shape");
      if (d > 0 && elements > std::numeric_limits<std::uint32_t>::max() / d) fail("dataset " + where + " is too large");
      elements *= d;
    }
    const std::uint64_t stored = h5::dataset_storage_bytes(group, name);
    if (elements * element_bytes > kMaxCompression * stored + 4096) {
      fail("dataset " + where + " claims " + std::to_string(elements) + " elements but the file holds " +
           std::to_string(stored) + " bytes of it");
    }
    return (*shape)[0];
  }

  template <typename T>
  std::vector<T> vector(hid_t group, const std::string& name, const std::string& where, ElementType type,
                        std::optional<hsize_t> expected = {}) const {
    std::vector<T> v(rows(group, name, where, {}, sizeof(T)));
    if (expected && v.size() != *expected) {
      fail("dataset " + where + " has " + std::to_string(v.size()) + " rows, expected " + std::to_string(*expected));
    }
    h5::read_dataset(group, name, type, v.data());
    return v;
  }

  /// An [F, N, 3] array as F matrices of 3×N.
  std::vector<Matrix3Xd> frames(hid_t group, const std::string& name, const std::string& where, hsize_t frame_count) const {
    const auto shape = h5::dataset_shape(group, name);
    if (rows(group, name, where, {0, 3}) != frame_count) fail("dataset " + where + " does not have one row per frame");
    const auto columns = static_cast<Eigen::Index>((*shape)[1]);
    std::vector<double> all(frame_count * static_cast<std::size_t>(columns) * 3);
    h5::read_dataset(group, name, ElementType::F64, all.data());
    std::vector<Matrix3Xd> out(frame_count, Matrix3Xd(3, columns));
    for (std::size_t f = 0; f < frame_count; ++f) {
      std::copy_n(all.begin() + static_cast<std::ptrdiff_t>(f * out[f].size()), out[f].size(), out[f].data());
    }
    return out;
  }

  [[nodiscard]] hid_t file() const { return m_file; }

 private:
  std::string m_path;
  hid_t m_file;
};

void read_bodies(const Reader& r, Trajectory& t) {
  const h5::Handle bodies = r.group(r.file(), "bodies", "/bodies");
  const std::vector<std::string> names = h5::list_links(bodies.id());
  t.bodies.resize(names.size());
  for (std::size_t b = 0; b < names.size(); ++b) {
    const std::string where = "/bodies/" + std::to_string(b);
    const h5::Handle g = r.group(bodies.id(), std::to_string(b), where);
    TrajectoryBody& body = t.bodies[b];
    body.name = h5::read_string_attribute(g.id(), "name").value_or("");
    body.frames = r.frames(g.id(), "positions", where + "/positions", t.time.size());
    const std::size_t nodes = body.frames.empty() ? 0 : static_cast<std::size_t>(body.frames[0].cols());
    body.split_from = r.vector<NodeIndex>(g.id(), "split_from", where + "/split_from", ElementType::U32, nodes);
  }
  if (!h5::has_link(r.file(), "projectiles")) return;  // version 1
  const h5::Handle projectiles = r.group(r.file(), "projectiles", "/projectiles");
  t.projectiles = r.frames(projectiles.id(), "positions", "/projectiles/positions", t.time.size());
}

void read_splits(const Reader& r, Trajectory& t) {
  const h5::Handle events = r.group(r.file(), "events", "/events");
  const h5::Handle group = r.group(events.id(), "splits", "/events/splits");
  const hid_t g = group.id();
  const std::string w = "/events/splits/";
  const auto step = r.vector<std::uint64_t>(g, "step", w + "step", ElementType::U64);
  const hsize_t s = step.size();
  const auto time = r.vector<double>(g, "time", w + "time", ElementType::F64, s);
  const auto body = r.vector<Index>(g, "body", w + "body", ElementType::U32, s);
  const auto node = r.vector<Index>(g, "node", w + "node", ElementType::U32, s);
  const auto added = r.vector<Index>(g, "added", w + "added", ElementType::U32, s);
  const auto eigenvalue = r.vector<double>(g, "eigenvalue", w + "eigenvalue", ElementType::F64, s);
  std::vector<double> normal(3 * s);
  if (r.rows(g, "normal", w + "normal", {3}) != s) r.fail("dataset " + w + "normal does not have one row per split");
  h5::read_dataset(g, "normal", ElementType::F64, normal.data());
  std::vector<std::uint64_t> offsets;
  std::vector<TetIndex> moved;
  if (t.version >= 2) {
    offsets = r.vector<std::uint64_t>(g, "moved_offsets", w + "moved_offsets", ElementType::U64, s + 1);
    moved = r.vector<TetIndex>(g, "moved_tets", w + "moved_tets", ElementType::U32);
    if (offsets.front() != 0 || offsets.back() != moved.size() || !std::is_sorted(offsets.begin(), offsets.end())) {
      r.fail("dataset " + w + "moved_offsets does not index " + w + "moved_tets");
    }
  }
  t.splits.resize(s);
  for (std::size_t i = 0; i < s; ++i) {
    TrajectorySplit& split = t.splits[i];
    split = {step[i], time[i], body[i], node[i], added[i], Vec3(normal[3 * i], normal[3 * i + 1], normal[3 * i + 2]),
             eigenvalue[i], {}};
    if (split.body >= t.bodies.size() || split.added >= t.bodies[split.body].split_from.size() ||
        split.node >= split.added || (i > 0 && split.step < t.splits[i - 1].step)) {
      r.fail("split " + std::to_string(i) + " in " + w + " does not fit the recorded bodies");
    }
    if (!offsets.empty()) split.moved.assign(moved.begin() + static_cast<std::ptrdiff_t>(offsets[i]),
                                             moved.begin() + static_cast<std::ptrdiff_t>(offsets[i + 1]));
  }
}

}  // namespace

void write_trajectory(const std::filesystem::path& path, const Trajectory& trajectory) {
  h5::write_file_atomically(path, [&](hid_t file) { write_contents(file, trajectory); });
}

namespace {

Trajectory read_trajectory_unprobed(const std::filesystem::path& path) {
  const h5::Handle file = h5::open_file_read_only(path.string());
  const Reader r(path.string(), file.id());
  if (h5::read_string_attribute(file.id(), "format").value_or("") != "fissure-trajectory") {
    r.fail("not a Fissure trajectory (no format attribute \"fissure-trajectory\")",
           "pass a file written by fissure-player run --trajectory");
  }
  Trajectory t;
  t.version = h5::read_integer_attribute(file.id(), "version").value_or(0);
  if (t.version < 1 || t.version > kTrajectoryVersion) {
    r.fail("trajectory version " + std::to_string(t.version) + " is not one this player reads (1 to " +
           std::to_string(kTrajectoryVersion) + ")", "record the run again with this player");
  }
  t.scene = h5::read_string_attribute(file.id(), "scene").value_or("");
  t.time = r.vector<double>(file.id(), "time", "/time", ElementType::F64);
  t.step = r.vector<std::uint64_t>(file.id(), "step", "/step", ElementType::U64, t.time.size());
  if (!std::is_sorted(t.step.begin(), t.step.end())) r.fail("/step is not in increasing order");
  read_bodies(r, t);
  read_splits(r, t);
  return t;
}

}  // namespace

Trajectory read_trajectory(const std::filesystem::path& path) {
  h5::require_legacy_file_readable(path, [&] { (void)read_trajectory_unprobed(path); });
  return read_trajectory_unprobed(path);
}

}  // namespace fissure::formats
