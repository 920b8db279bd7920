#include "formats/trajectory.h"

#include <limits>

#include "formats/hdf5_io.h"

namespace fissure::formats {

namespace {

template <typename T>
std::vector<T> column(const auto& records, auto member) {
  std::vector<T> out;
  out.reserve(records.size());
  for (const auto& r : records) out.push_back(static_cast<T>(r.*member));
  return out;
}

void write_contents(hid_t file, const Trajectory& t) {
  using h5::ElementType;
  h5::write_attribute(file, "format", std::string("fissure-trajectory"));
  h5::write_attribute(file, "version", std::int64_t{1});
  h5::write_attribute(file, "scene", t.scene);
  const hsize_t frames = t.time.size();
  h5::write_dataset(file, "time", ElementType::F64, {frames}, t.time.data());
  h5::write_dataset(file, "step", ElementType::U64, {frames}, t.step.data());
  const h5::Handle bodies = h5::create_group(file, "bodies");
  for (std::size_t b = 0; b < t.bodies.size(); ++b) {
    const TrajectoryBody& body = t.bodies[b];
    const h5::Handle group = h5::create_group(bodies.id(), std::to_string(b));
    h5::write_attribute(group.id(), "name", body.name);
    const std::size_t nodes = body.split_from.size();
    std::vector<double> positions(frames * nodes * 3, std::numeric_limits<double>::quiet_NaN());
    for (std::size_t f = 0; f < body.frames.size(); ++f) {
      const Matrix3Xd& x = body.frames[f];
      std::copy(x.data(), x.data() + x.size(), positions.begin() + static_cast<std::ptrdiff_t>(f * nodes * 3));
    }
    h5::write_dataset(group.id(), "positions", ElementType::F64, {frames, nodes, 3}, positions.data());
    h5::write_dataset(group.id(), "split_from", ElementType::U32, {nodes}, body.split_from.data());
  }
  const h5::Handle events = h5::create_group(file, "events");
  const h5::Handle splits = h5::create_group(events.id(), "splits");
  const hsize_t s = t.splits.size();
  h5::write_dataset(splits.id(), "step", ElementType::U64, {s}, column<std::uint64_t>(t.splits, &TrajectorySplit::step).data());
  h5::write_dataset(splits.id(), "time", ElementType::F64, {s}, column<double>(t.splits, &TrajectorySplit::time).data());
  h5::write_dataset(splits.id(), "body", ElementType::U32, {s}, column<Index>(t.splits, &TrajectorySplit::body).data());
  h5::write_dataset(splits.id(), "node", ElementType::U32, {s}, column<Index>(t.splits, &TrajectorySplit::node).data());
  h5::write_dataset(splits.id(), "added", ElementType::U32, {s}, column<Index>(t.splits, &TrajectorySplit::added).data());
  h5::write_dataset(splits.id(), "eigenvalue", ElementType::F64, {s},
                    column<double>(t.splits, &TrajectorySplit::eigenvalue).data());
  std::vector<double> normals;
  for (const TrajectorySplit& split : t.splits) normals.insert(normals.end(), split.normal.data(), split.normal.data() + 3);
  h5::write_dataset(splits.id(), "normal", ElementType::F64, {s, 3}, normals.data());
  const h5::Handle exposed = h5::create_group(events.id(), "exposed_faces");
  const hsize_t e = t.exposed_faces.size();
  using Face = TrajectoryExposedFace;
  h5::write_dataset(exposed.id(), "step", ElementType::U64, {e}, column<std::uint64_t>(t.exposed_faces, &Face::step).data());
  h5::write_dataset(exposed.id(), "body", ElementType::U32, {e}, column<Index>(t.exposed_faces, &Face::body).data());
  h5::write_dataset(exposed.id(), "tet", ElementType::U32, {e}, column<Index>(t.exposed_faces, &Face::tet).data());
  h5::write_dataset(exposed.id(), "face", ElementType::U8, {e}, column<std::uint8_t>(t.exposed_faces, &Face::face).data());
}

}  // namespace

void write_trajectory(const std::filesystem::path& path, const Trajectory& trajectory) {
  h5::write_file_atomically(path, [&](hid_t file) { write_contents(file, trajectory); });
}

}  // namespace fissure::formats
