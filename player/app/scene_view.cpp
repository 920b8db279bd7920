#include "player/app/scene_view.h"

#include <cmath>
#include <limits>
#include <optional>

#include "common/tet_mesh.h"
#include "player/render/shapes.h"

namespace fissure::player {

namespace {

using render::Vec3f;

/// An axis-aligned box, each face its own four vertices so normals are flat.
render::PlainMesh box(const Vec3& lo, const Vec3& hi) {
  render::PlainMesh mesh;
  for (int axis = 0; axis < 3; ++axis) {
    for (const int side : {0, 1}) {
      Vec3f normal = Vec3f::Zero();
      normal[axis] = side == 0 ? -1.0f : 1.0f;
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      const auto first = static_cast<std::uint32_t>(mesh.positions.size() / 3);
      for (const auto& [a, b] : {std::pair{0, 0}, {1, 0}, {1, 1}, {0, 1}}) {
        Vec3 p;
        p[axis] = side == 0 ? lo[axis] : hi[axis];
        p[u] = a == 0 ? lo[u] : hi[u];
        p[v] = b == 0 ? lo[v] : hi[v];
        mesh.positions.insert(mesh.positions.end(), {float(p.x()), float(p.y()), float(p.z())});
        mesh.normals.insert(mesh.normals.end(), {normal.x(), normal.y(), normal.z()});
      }
      mesh.triangles.insert(mesh.triangles.end(), {first, first + 1, first + 2, first, first + 2, first + 3});
    }
  }
  return mesh;
}

/// A round number of metres near `length`: 1, 2 or 5 times a power of ten.
double round_length(double length) {
  const double power = std::pow(10.0, std::floor(std::log10(length)));
  const double mantissa = length / power;
  return power * (mantissa < 1.5 ? 1.0 : mantissa < 3.5 ? 2.0 : mantissa < 7.5 ? 5.0 : 10.0);
}

render::Mat4f placed(const Vec3& centre, double radius) {
  render::Mat4f m = render::Mat4f::Identity();
  m.topLeftCorner<3, 3>() *= static_cast<float>(radius);
  m.topRightCorner<3, 1>() = centre.cast<float>();
  return m;
}

Vec3 world_up(const sim::World& world) {
  if (world.environment().ground) return world.environment().ground->normal.normalized();
  const Vec3& g = world.settings().step.gravity;
  return g.norm() > 0.0 ? Vec3(-g.normalized()) : Vec3(Vec3::UnitZ());
}

/// The bodies' centre of mass (their nodes' lumped masses), or nothing when no node
/// has a finite position.
std::optional<Vec3> centre_of_mass(const sim::World& world) {
  Vec3 moment = Vec3::Zero();
  double mass = 0.0;
  for (const sim::Body& body : world.bodies()) {
    const Matrix3Xd& x = body.integrator().positions();
    const Eigen::VectorXd& m = body.integrator().node_masses();
    for (Eigen::Index n = 0; n < x.cols(); ++n) {
      if (!x.col(n).allFinite()) continue;
      moment += m[n] * x.col(n);
      mass += m[n];
    }
  }
  if (!(mass > 0.0)) return std::nullopt;
  return moment / mass;
}

}  // namespace

/// How far tessellated relief may raise or sink an interior wall, as a fraction of the
/// detail's period (a quarter of the cage's mean edge): deep enough to break the flat
/// look of a cut at the distance a piece is seen from, shallow enough that the
/// normal-mapped slopes still match. The bake's clearance caps it further per face.
constexpr double kReliefOfPeriod = 0.25;

/// The walls' per-slot tables (renderer.h): which tile each (tet, local face) shows,
/// and where each of its corners sits in the tile (texel (i, j) lies at face point
/// n0 + u (n1 − n0) + v (n2 − n0) with (n0, n1, n2) the face's nodes in the table);
/// the detail's repeat and the relief allowed, in world metres (`scale`: the scene's).
void add_wall_tables(const formats::Bundle& bundle, double scale, render::EmbeddedMesh& mesh) {
  const std::size_t tets = bundle.cage.tet_count();
  mesh.face_tile.assign(4 * tets, render::kWallNone);
  mesh.face_uv.assign(24 * tets, 0.0f);
  if (!bundle.walls) return;  // no walls stage: which part of a face is solid is unknown
  const formats::Walls& w = *bundle.walls;
  for (TetIndex t = 0; t < tets; ++t) {
    for (int k = 0; k < 4; ++k) {
      const std::size_t slot = 4 * static_cast<std::size_t>(t) + static_cast<std::size_t>(k);
      const FaceIndex f = bundle.faces.tet_faces(k, t);
      const formats::FaceClass cls = w.face_class[f];
      mesh.face_tile[slot] = cls == formats::FaceClass::Crossing ? static_cast<std::int32_t>(w.face_tile[f])
                             : cls == formats::FaceClass::Inside ? render::kWallWhole
                                                                 : render::kWallNone;
      for (int j = 0; j < 3; ++j) {
        const Index node = bundle.cage.tets(kTetFaceNodes[k][j], t);
        float* uv = &mesh.face_uv[6 * slot + 2 * static_cast<std::size_t>(j)];
        uv[0] = node == bundle.faces.nodes(1, f) ? 1.0f : 0.0f;
        uv[1] = node == bundle.faces.nodes(2, f) ? 1.0f : 0.0f;
      }
    }
  }
  mesh.tile_resolution = static_cast<int>(w.resolution);
  if (w.sdf_range_texels > 0.0) mesh.tile_range_texels = static_cast<float>(w.sdf_range_texels);
  mesh.tiles = w.sdf;
  // The detail repeats every quarter of the cage's mean edge, on every face alike.
  mesh.detail_resolution = static_cast<int>(w.detail_resolution);
  mesh.detail_normal = w.detail_normal;
  double edges = 0.0;
  for (FaceIndex f = 0; f < bundle.faces.face_count(); ++f) {
    edges += (bundle.cage.rest_positions.col(bundle.faces.nodes(1, f)) - bundle.cage.rest_positions.col(bundle.faces.nodes(0, f))).norm();
  }
  const double period = 0.25 * edges / static_cast<double>(std::max<std::size_t>(bundle.faces.face_count(), 1));
  mesh.face_detail_repeat.assign(8 * tets, 1.0f);
  // Relief on inside faces only, and only with a clearance (bundles from schema 1.0
  // have none: their walls stay flat).
  mesh.face_relief.assign(4 * tets, 0.0f);
  if (!w.face_clearance.empty()) mesh.detail_height = w.detail_height;
  for (TetIndex t = 0; t < tets; ++t) {
    for (int k = 0; k < 4; ++k) {
      const std::size_t slot = 4 * static_cast<std::size_t>(t) + static_cast<std::size_t>(k);
      const FaceIndex f = bundle.faces.tet_faces(k, t);
      const auto& n = bundle.faces.nodes;
      const Matrix3Xd& x = bundle.cage.rest_positions;
      float* repeat = &mesh.face_detail_repeat[2 * slot];
      repeat[0] = static_cast<float>((x.col(n(1, f)) - x.col(n(0, f))).norm() / period);
      repeat[1] = static_cast<float>((x.col(n(2, f)) - x.col(n(0, f))).norm() / period);
      if (!w.face_clearance.empty() && w.face_class[f] == formats::FaceClass::Inside) {
        mesh.face_relief[slot] = static_cast<float>(scale * std::min(w.face_clearance[f], kReliefOfPeriod * period));
      }
    }
  }
}

void add_collision_spheres(const sim::EmbeddedPoints& spheres, render::EmbeddedMesh& mesh) {
  for (std::size_t k = 0; k < spheres.size(); ++k) {
    mesh.sphere_tet.push_back(spheres.tet[k]);
    const Vec4& b = spheres.barycentric[k];
    mesh.sphere_barycentric.insert(mesh.sphere_barycentric.end(), {float(b[0]), float(b[1]), float(b[2]), float(b[3])});
    mesh.sphere_radius.push_back(static_cast<float>(spheres.radius[k]));
  }
}

render::EmbeddedMesh embedded_mesh(const formats::Bundle& bundle, const sim::ImplicitIntegrator& body, double scale) {
  const formats::Embedding& e = bundle.embedding;
  const Matrix3Xd& rest = body.rest_positions();
  const Matrix4Xu& tets = body.elasticity().tets();
  const auto corner_position = [&](std::size_t instance, int corner) {
    const Vec4 b = e.instance_barycentric[instance].col(corner);
    const TetIndex t = e.instance_tet[instance];
    return Vec3(b[0] * rest.col(tets(0, t)) + b[1] * rest.col(tets(1, t)) + b[2] * rest.col(tets(2, t)) +
                b[3] * rest.col(tets(3, t)));
  };
  // Smooth normals: each vertex sums its triangles' area-weighted normals, every
  // triangle placed once (by its first instance; instances are sorted by triangle).
  Matrix3Xd normals = Matrix3Xd::Zero(3, bundle.render.positions.cols());
  for (std::size_t i = 0; i < e.instance_count(); ++i) {
    if (i > 0 && e.instance_triangle[i] == e.instance_triangle[i - 1]) continue;
    const Vec3 a = corner_position(i, 0), b = corner_position(i, 1), c = corner_position(i, 2);
    const Vec3 n = (b - a).cross(c - a);
    for (int j = 0; j < 3; ++j) normals.col(bundle.render.triangles(j, e.instance_triangle[i])) += n;
  }
  render::EmbeddedMesh mesh;
  mesh.barycentric.reserve(12 * e.instance_count());
  for (std::size_t i = 0; i < e.instance_count(); ++i) {
    for (int j = 0; j < 3; ++j) {
      const Vec4 b = e.instance_barycentric[i].col(j);
      mesh.barycentric.insert(mesh.barycentric.end(), {float(b[0]), float(b[1]), float(b[2]), float(b[3])});
      mesh.tet.push_back(e.instance_tet[i]);
      const Vec3 n = normals.col(bundle.render.triangles(j, e.instance_triangle[i])).normalized();
      mesh.rest_normal.insert(mesh.rest_normal.end(), {float(n.x()), float(n.y()), float(n.z())});
    }
  }
  // The replication view's count per instance: instances of one triangle are adjacent.
  mesh.instance_replicas.resize(e.instance_count());
  for (std::size_t first = 0, next = 0; first < e.instance_count(); first = next) {
    while (next < e.instance_count() && e.instance_triangle[next] == e.instance_triangle[first]) ++next;
    std::fill(mesh.instance_replicas.begin() + static_cast<std::ptrdiff_t>(first),
              mesh.instance_replicas.begin() + static_cast<std::ptrdiff_t>(next), static_cast<std::uint32_t>(next - first));
  }
  mesh.rest_inverse.reserve(9 * static_cast<std::size_t>(tets.cols()));
  for (Eigen::Index t = 0; t < tets.cols(); ++t) {
    Mat3 edges;
    for (int i = 0; i < 3; ++i) edges.col(i) = rest.col(tets(i + 1, t)) - rest.col(tets(0, t));
    const Mat3 inverse = edges.inverse();
    mesh.rest_inverse.insert(mesh.rest_inverse.end(), inverse.data(), inverse.data() + 9);
  }
  add_wall_tables(bundle, scale, mesh);
  return mesh;
}

SceneView::SceneView(const sim::World& world, const std::vector<BodyAssets>& assets, render::Renderer& renderer,
                     const std::optional<formats::SceneCamera>& camera)
    : m_renderer(renderer), m_frames(world.bodies().size()) {
  Eigen::AlignedBox3d bounds;
  for (std::size_t b = 0; b < world.bodies().size(); ++b) {
    const sim::ImplicitIntegrator& body = world.bodies()[b].integrator();
    render::EmbeddedMesh mesh = embedded_mesh(assets[b].bundle, body, assets[b].scale);
    add_collision_spheres(world.bodies()[b].spheres, mesh);
    if (assets[b].color) mesh.color = assets[b].color->cast<float>();
    if (assets[b].interior_color) mesh.interior_color = assets[b].interior_color->cast<float>();
    m_bodies.push_back(renderer.add_body(mesh));
    for (Eigen::Index n = 0; n < body.positions().cols(); ++n) bounds.extend(Vec3(body.positions().col(n)));
  }
  if (bounds.isEmpty()) bounds.extend(Vec3::Zero());
  const double size = std::max(bounds.diagonal().norm(), 1e-3);
  const sim::Environment& environment = world.environment();
  if (environment.ground) {
    // A checker of about a third of the bodies' size in round metres, so its cells give
    // scale and motion; the sky turns from a light horizon (the ground fades into it) to
    // a soft blue overhead.
    const sim::Plane& plane = *environment.ground;
    const double length = plane.normal.norm();
    render::Ground ground;
    ground.normal = (plane.normal / length).cast<float>();
    ground.offset = static_cast<float>(plane.offset / length);
    ground.cell = static_cast<float>(round_length(size / 3.0));
    renderer.set_ground(ground);
    renderer.set_sky({Vec3f(0.86f, 0.88f, 0.91f), Vec3f(0.56f, 0.68f, 0.86f)});
  }
  for (const sim::Box& b : environment.boxes) renderer.add_plain(box(b.min, b.max));
  const render::PlainMesh sphere = render::unit_sphere(24, 48);
  for (const sim::Ball& b : environment.balls) renderer.set_transform(renderer.add_plain(sphere), placed(b.center, b.radius));
  m_projectile_mesh = sphere;
  m_projectile_mesh.color = Vec3f(0.75f, 0.30f, 0.22f);
  // Frame the bodies with a margin of a tenth of their size (update() follows them):
  // from the front, a little above, with the world's up (the ground's normal, else
  // against gravity) at the top, and the light above.
  const Vec3 margin = 0.1 * (bounds.max() - bounds.min());
  const Eigen::AlignedBox3f view_box((bounds.min() - margin).cast<float>(), (bounds.max() + margin).cast<float>());
  const float aspect = static_cast<float>(renderer.width()) / static_cast<float>(renderer.height());
  const Vec3f up = world_up(world).cast<float>();
  const Eigen::Quaternionf z_to_up = Eigen::Quaternionf::FromTwoVectors(Vec3f::UnitZ(), up);
  m_camera = render::frame_box(view_box, z_to_up * Vec3f(-0.55f, 0.75f, -0.38f), up, 30.0f, aspect);
  m_start_centre = centre_of_mass(world).value_or(bounds.center());
  if (camera) {
    m_follow = false;
    m_camera.eye = camera->position.cast<float>();
    m_camera.target = camera->target.cast<float>();
    m_camera.fov_y_degrees = static_cast<float>(camera->fov_degrees);
    m_camera.up = camera->up ? Vec3f(camera->up->cast<float>()) : up;
    // The world's up may run along the view (a camera looking straight down): then any
    // direction across the view will do, as in frame_box.
    const Vec3f view = (m_camera.target - m_camera.eye).normalized();
    if (std::abs(view.dot(m_camera.up.normalized())) > 0.999f) m_camera.up = m_camera.up.unitOrthogonal();
    const float distance = (m_camera.target - m_camera.eye).norm();
    const float size = std::max(static_cast<float>(bounds.diagonal().norm()), 1e-3f);
    m_camera.near_plane = std::max(1e-3f * distance, 0.01f * size);
    m_camera.far_plane = distance + 100.0f * size;
  }
  m_start_camera = m_camera;
  m_start_follow = m_follow;
  render::Light light;
  light.towards = z_to_up * light.towards;
  renderer.set_light(light);
  update(world);
}

void SceneView::fit_planes(const sim::World& world, render::Camera& camera) const {
  // The near and far planes widen, never narrow, from the starting view's to hold every
  // body and launched projectile as they are now: a piece or a ball that comes closer
  // than frame 0's near plane, or goes beyond its far one, stays in the picture.
  const Vec3f view = (camera.target - camera.eye).normalized();
  float nearest = std::numeric_limits<float>::infinity(), farthest = 0.0f;
  const auto include = [&](const Vec3& point, double radius) {
    if (!point.allFinite()) return;
    const float depth = (point.cast<float>() - camera.eye).dot(view);
    nearest = std::min(nearest, depth - static_cast<float>(radius));
    farthest = std::max(farthest, depth + static_cast<float>(radius));
  };
  for (const sim::Body& body : world.bodies()) {
    const Matrix3Xd& x = body.integrator().positions();
    for (Eigen::Index n = 0; n < x.cols(); ++n) include(x.col(n), 0.0);
  }
  for (const sim::Projectile& p : world.projectiles()) {
    if (p.launched) include(p.position, p.radius);
  }
  const float distance = (camera.target - camera.eye).norm();
  camera.near_plane = std::min(m_camera.near_plane, std::max(0.9f * nearest, 1e-3f * distance));
  camera.far_plane = std::max(m_camera.far_plane, 1.1f * farthest);
}

void SceneView::set_camera(const render::Camera& camera) {
  m_follow = false;
  m_camera = m_current = camera;
  m_renderer.set_camera(camera);
}

void SceneView::restore_camera() {
  m_camera = m_start_camera;
  m_follow = m_start_follow;
}

void SceneView::update(const sim::World& world) {
  // Follow the bodies' centre of mass, keeping the starting view's offset. Not the
  // centre of their bounds: once a hit throws a few small fragments far off, that
  // centre lies between them and the body, and the body leaves the view (the sample's
  // video lost the bunny from t = 1.4 s on).
  render::Camera camera = m_camera;
  if (const std::optional<Vec3> centre = centre_of_mass(world); m_follow && centre) {
    const Vec3f shift = (*centre - m_start_centre).cast<float>();
    camera.eye += shift;
    camera.target += shift;
  }
  fit_planes(world, camera);
  m_renderer.set_camera(camera);
  m_current = camera;
  for (std::size_t b = 0; b < m_bodies.size(); ++b) {
    update_render_frame(world.frame(b, false), m_frames[b]);  // the renderer makes F itself
    const RenderFrame& f = m_frames[b];
    m_renderer.set_pose(m_bodies[b], {f.positions, f.tets, f.faces, f.fragment, f.topology_version});
  }
  while (m_projectiles.size() < world.projectiles().size()) m_projectiles.push_back(m_renderer.add_plain(m_projectile_mesh));
  for (std::size_t j = 0; j < m_projectiles.size(); ++j) {
    const sim::Projectile& p = world.projectiles()[j];
    m_renderer.set_visible(m_projectiles[j], p.launched);
    m_renderer.set_transform(m_projectiles[j], placed(p.position, p.radius));
  }
}

}  // namespace fissure::player
