#include "player/app/scene_loader.h"

#include <cmath>
#include <numbers>

#include "common/error.h"
#include "common/log.h"
#include "formats/bundle.h"
#include "formats/bundle_checks.h"
#include "formats/vertex_instances.h"

namespace fissure::player {

namespace {

sim::ContactMaterial contact(double restitution, double friction, double rolling_resistance) {
  return {restitution, friction, rolling_resistance};
}

sim::ExactResolve exact_resolve(formats::SceneExact exact) {
  switch (exact) {
    case formats::SceneExact::Never: return sim::ExactResolve::Never;
    case formats::SceneExact::Solve: return sim::ExactResolve::Solve;
    case formats::SceneExact::Contacts: return sim::ExactResolve::SolveAndContacts;
  }
  return sim::ExactResolve::Solve;
}

/// Every render vertex once, bound to the tet that moves it (formats::vertex_instances).
sim::EmbeddedPoints render_vertices(const formats::Bundle& bundle) {
  // Each vertex follows the tet it is deepest inside: the first instance's tet held only
  // 1,369 of the sample bunny's 2,502 vertices, and a vertex carried by a tet that does
  // not hold it (coordinates down to -0.88) went where nothing is drawn once fracture
  // freed that tet (issue 42: 24 mm "in the ground").
  const auto& e = bundle.embedding;
  sim::EmbeddedPoints points;
  for (const formats::VertexInstance& held : formats::vertex_instances(bundle)) {
    if (held.instance == formats::kNoInstance) continue;  // a vertex no triangle uses
    points.tet.push_back(e.instance_tet[held.instance]);
    points.barycentric.push_back(e.instance_barycentric[held.instance].col(held.corner));
    points.radius.push_back(0.0);
  }
  return points;
}

/// "scene.toml:12: object[0] 'bunny'", the prefix of every error about one object.
std::string object_where(const formats::Scene& scene, std::size_t index) {
  const formats::SceneObject& object = scene.objects[index];
  return scene.file.string() + ":" + std::to_string(object.line) + ": object[" + std::to_string(index) + "] '" +
         object.name + "'";
}

/// Reads the object's bundle and runs every check `fissure-bake verify` runs (about
/// 30 ms for the sample bunny): the player never simulates a bundle verify rejects.
formats::Bundle read_checked_bundle(const formats::Scene& scene, std::size_t index) {
  const formats::SceneObject& object = scene.objects[index];
  const std::string where = object_where(scene, index) + ".bundle " + object.bundle.string();
  formats::Bundle bundle;
  try {
    bundle = formats::read_bundle(object.bundle);
  } catch (const Error& e) {
    throw Error(object_where(scene, index) + ".bundle: " + e.what(), e.hint());
  }
  const formats::VerifyReport report = formats::verify_bundle(bundle);
  if (report.passed()) return bundle;
  std::string failures;
  for (const auto& check : report.checks) {
    if (!check.passed) failures += "\n  " + check.name + ": " + check.detail;
  }
  throw Error(where + " fails its checks (the file is corrupt or was not written by fissure-bake):" + failures,
              "run `fissure-bake verify " + object.bundle.string() + "` for the whole report, and bake it again");
}

/// The placed cage must still be a valid solid: a scale or translation near the
/// largest double overflows, and a tiny scale underflows the volumes.
void require_placed_cage_valid(const sim::BodyDescription& d, const std::string& where) {
  if (!d.rest.allFinite()) {
    throw Error(where + ": the transform (scale, rotation, translation) makes cage positions overflow",
                "use scale and translation in metres, well below 1e150");
  }
  for (Eigen::Index t = 0; t < d.tets.cols(); ++t) {
    const auto x = [&](int k) -> Vec3 { return d.rest.col(d.tets(k, t)); };
    const double volume = (x(1) - x(0)).cross(x(2) - x(0)).dot(x(3) - x(0)) / 6.0;
    if (!(volume > 0.0) || !std::isfinite(volume)) {
      throw Error(where + ": after the scale, tet " + std::to_string(t) + " has volume " + std::to_string(volume),
                  "scale the object so its tets keep a finite, positive volume (e.g. 1e-4 … 1e4)");
    }
  }
}

sim::BodyDescription describe(const formats::Scene& scene, std::size_t index, const formats::Bundle& bundle) {
  const formats::SceneObject& object = scene.objects[index];
  const std::string where = object_where(scene, index);
  sim::BodyDescription d;
  d.name = object.name;
  const Eigen::AngleAxisd rotation(object.rotation_degrees * std::numbers::pi / 180.0, object.rotation_axis);
  d.rest = (rotation.toRotationMatrix() * (object.scale * bundle.cage.rest_positions)).colwise() + object.translation;
  d.tets = bundle.cage.tets;
  require_placed_cage_valid(d, where);
  const formats::SceneMaterial& m = object.material;
  d.material = {m.density, m.youngs_modulus, m.poisson_ratio, m.rayleigh_mass, m.rayleigh_stiffness};
  d.toughness = m.toughness;
  d.contact = contact(m.restitution, m.friction, m.rolling_resistance);
  if (bundle.collision) {
    const formats::Collision& c = *bundle.collision;
    d.spheres.tet = c.sphere_tet;
    d.spheres.barycentric = c.sphere_barycentric;
    d.spheres.radius = c.sphere_radius;
    for (double& r : d.spheres.radius) r *= object.scale;
    d.reserve_spheres.tet = c.reserve_tet;
    d.reserve_spheres.barycentric = c.reserve_barycentric;
    d.reserve_spheres.radius = c.reserve_radius;
    for (double& r : d.reserve_spheres.radius) r *= object.scale;
    d.reserve_cover = c.reserve_cover_tet;
    if (scene.features.mass_weighting) d.mass = sim::MassDistribution{c.mass_fraction, c.center_of_mass};
  } else {
    log_warning(where + ": the bundle has no collision stage: using one inscribed sphere per tet and uniform mass");
  }
  d.vertices = render_vertices(bundle);
  const auto node_count = static_cast<Index>(d.rest.cols());
  std::vector<std::uint8_t> pinned(node_count, 0);
  for (const Index n : object.pin_nodes) {
    if (n >= node_count) {
      throw Error(where + ": pinned node " + std::to_string(n) + " does not exist (the cage has " +
                      std::to_string(node_count) + " nodes)",
                  "node indices are 0-based; `fissure-bake inspect` shows the cage size");
    }
    pinned[n] = 1;
  }
  for (const formats::ScenePinBox& box : object.pin_boxes) {
    std::size_t hits = 0;
    for (Index n = 0; n < node_count; ++n) {
      const Vec3 x = d.rest.col(n);
      if ((x.array() >= box.min.array()).all() && (x.array() <= box.max.array()).all()) {
        pinned[n] = 1;
        ++hits;
      }
    }
    if (hits == 0) {
      log_warning(where + ": a pin box holds no cage node (boxes are in world coordinates, after the transform)");
    }
  }
  for (Index n = 0; n < node_count; ++n) {
    if (pinned[n]) d.pinned.push_back(n);
  }
  const Vec3 centroid = d.rest.rowwise().mean();
  d.velocity.resize(3, node_count);
  for (Index n = 0; n < node_count; ++n) {
    d.velocity.col(n) = object.velocity + object.angular_velocity.cross(d.rest.col(n) - centroid);
  }
  return d;
}

/// What a scene may load in all (issue 46): 256 overlapping bunnies held 3 GB before
/// their first step. Spheres bound the contacts a step can find: 256 small bodies of
/// 1,408 spheres each piled in one place (360,448) found 14.9 M contacts and took 13 s a
/// step (issue 42's spheres, which follow the solid, not the cage). The sample bunny has
/// 1,764 spheres, so ~140 of them fit.
constexpr std::size_t kMaxSceneSpheres = 250'000;
constexpr std::size_t kMaxSceneTets = 1'000'000;

/// Adds object `i`'s bundle to the scene's totals; throws naming the object, the count
/// and the limit when a total passes its limit.
void count_scene_size(const formats::Scene& scene, std::size_t i, const formats::Bundle& bundle, std::size_t& spheres,
                      std::size_t& tets) {
  spheres += bundle.collision ? bundle.collision->sphere_tet.size() + bundle.collision->reserve_tet.size() : 0;
  tets += bundle.cage.tet_count();
  const auto refuse = [&](const char* what, std::size_t count, std::size_t limit) {
    throw Error(scene.file.string() + ":" + std::to_string(scene.objects[i].line) + ": object[" + std::to_string(i) +
                    "] brings the scene to " + std::to_string(count) + " " + what + ", more than the " +
                    std::to_string(limit) + " a scene may hold (" + std::to_string(scene.objects.size()) + " objects)",
                "use fewer objects, or bundles baked with a coarser cage or a larger --sphere-radius");
  };
  if (spheres > kMaxSceneSpheres) refuse("collision spheres", spheres, kMaxSceneSpheres);
  if (tets > kMaxSceneTets) refuse("cage tets", tets, kMaxSceneTets);
}

}  // namespace

LoadedScene load_scene(const formats::Scene& scene) {
  std::vector<sim::BodyDescription> bodies;
  std::vector<BodyAssets> assets;
  std::size_t total_spheres = 0, total_tets = 0;
  for (std::size_t i = 0; i < scene.objects.size(); ++i) {
    const formats::SceneObject& object = scene.objects[i];
    std::error_code ec;  // a link loop or an unreadable folder is read_bundle's error, not an exception here
    if (!std::filesystem::exists(object.bundle, ec) && !ec) {
      throw Error(scene.file.string() + ":" + std::to_string(object.line) + ": object[" + std::to_string(i) +
                      "].bundle " + object.bundle.string() + " does not exist",
                  "paths are relative to the scene file's folder; bake the bundle with `fissure-bake bake` first");
    }
    formats::Bundle bundle = read_checked_bundle(scene, i);
    count_scene_size(scene, i, bundle, total_spheres, total_tets);
    bodies.push_back(describe(scene, i, bundle));
    assets.push_back({object.bundle.filename().string(), std::move(bundle), object.scale, object.color, object.interior_color});
  }
  sim::Environment environment;
  if (scene.ground.enabled) {
    environment.ground = sim::Plane{scene.ground.normal, scene.ground.offset,
                                    contact(scene.ground.restitution, scene.ground.friction, scene.ground.rolling_resistance)};
  }
  for (const auto& b : scene.boxes) environment.boxes.push_back({b.min, b.max, contact(b.restitution, b.friction, b.rolling_resistance)});
  for (const auto& s : scene.spheres) {
    environment.balls.push_back({s.center, s.radius, contact(s.restitution, s.friction, s.rolling_resistance)});
  }
  std::vector<sim::Projectile> projectiles;
  for (const auto& p : scene.projectiles) {
    projectiles.push_back({p.position, p.velocity, p.radius, p.mass, p.launch_time, contact(p.restitution, p.friction, p.rolling_resistance)});
  }
  sim::WorldSettings settings;
  settings.step.dt = scene.solver.dt;
  settings.step.gravity = scene.gravity;
  settings.step.solver = scene.solver.solver == formats::SceneSolver::Direct ? sim::LinearSolver::Direct
                                                                             : sim::LinearSolver::ConjugateGradient;
  settings.step.stiffness = scene.solver.stiffness == formats::SceneStiffness::Exact ? sim::StiffnessModel::Exact
                                                                                     : sim::StiffnessModel::Warped;
  settings.step.tolerance = scene.solver.tolerance;
  settings.step.max_iterations = scene.solver.max_iterations;
  settings.step.preconditioner = scene.solver.preconditioner == formats::ScenePreconditioner::Jacobi
                                     ? sim::Preconditioner::Jacobi
                                     : sim::Preconditioner::LaggedCholesky;
  settings.step.refactor_iterations = scene.solver.refactor_iterations;
  settings.step.loose_node_slots = scene.solver.loose_node_slots;
  settings.rotate_on_arcs = scene.solver.rotation == formats::SceneRotation::Arc;
  settings.exact_when_gaining = exact_resolve(scene.solver.exact_when_gaining);
  settings.exact_gain_share = scene.solver.exact_gain_share;
  settings.energy_halvings = scene.solver.energy_halvings;
  settings.rigid_when_gaining_below = scene.solver.rigid_when_gaining_below;
  settings.contacts.iterations = scene.solver.contact_iterations;
  settings.contacts.sequential_impulse_sweeps = scene.solver.contact_sweeps;
  settings.contacts.rigid_resting_speed = formats::rigid_resting_speed(scene);
  settings.contacts.rigid_fragments_below = scene.solver.rigid_fragments_below;
  settings.sleep = {scene.solver.sleep_speed, scene.solver.sleep_time};
  settings.min_dt = scene.solver.min_dt;
  settings.max_substep = scene.solver.max_substep;
  settings.fracture = scene.features.fracture;
  settings.max_splits_per_step = scene.solver.max_splits_per_step;
  settings.collisions = scene.features.collisions;
  settings.self_collision = scene.features.self_collision;
  settings.collision_points = scene.features.collision_mode == formats::SceneCollisionMode::Vertices
                                  ? sim::CollisionPoints::RenderVertices
                                  : sim::CollisionPoints::Spheres;
  return {sim::World(std::move(bodies), std::move(environment), std::move(projectiles), settings), std::move(assets), scene.camera};
}

}  // namespace fissure::player
