#include "formats/scene.h"

// The only translation unit that sees toml++ (through scene_table.h). The Debian
// package ships it compiled (libtomlplusplus.so, TOML_HEADER_ONLY=0 via the CMake
// target), which compiles this file several times faster than the header-only build.
#include "formats/scene_table.h"

#include <algorithm>
#include <charconv>
#include <climits>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <initializer_list>
#include <optional>
#include <sstream>
#include <utility>

#include "common/error.h"
#include "common/input_file.h"

namespace fissure::formats {
namespace {

using namespace scene_detail;

// Range predicates shared by many keys.
constexpr auto kPositive = [](double v) { return v > 0; };
constexpr auto kNonNegative = [](double v) { return v >= 0; };
constexpr auto kUnit = [](double v) { return v >= 0 && v <= 1; };

// Magnitudes beyond which a scene leaves the range issue 16's extremes grid covers and
// heads for energies that overflow a double (½mv², m·g·h at 1e300): rejected here, where
// the message can name the key, rather than steps later as "the energy became
// non-finite" with no key to change.
constexpr double kMaxGravity = 1e4;          // [m/s²], about 1,000 g
constexpr double kMaxSpeed = 1e4;            // [m/s], ten times a rifle bullet
constexpr double kMaxAngularSpeed = 1e4;     // [rad/s]
constexpr double kMaxDistance = 1e6;         // [m] from the origin: 1e-10 m resolution left in a double
constexpr double kMaxYoungsModulus = 1e13;   // [Pa], ten times diamond
// Each halving can double a substep's cost where energy keeps appearing; 2^20 substeps
// of one is already far past a usable run.
constexpr int kMaxEnergyHalvings = 20;
constexpr int kMaxContactIterations = 64;  // 8 is the default; a pile's shortfall hardly moves after that
constexpr int kMaxContactSweeps = 1024;    // 16 is the default; each sweep is a pass over the contacts
const std::string kSpeedRange = "a speed of at most 1e4 m/s";
const std::string kPositionRange = "at most 1e6 m from the origin";

void read_contact(const Table& t, double& restitution, double& friction, double& rolling_resistance) {
  t.read_number("restitution", restitution, kUnit, "0 <= restitution <= 1");
  t.read_number("friction", friction, kNonNegative, "friction >= 0 (Coulomb coefficient)");
  t.read_number("rolling_resistance", rolling_resistance, kNonNegative,
                "rolling_resistance >= 0 (the resisting couple's lever, a share of the sphere's radius)");
}

/// min and max of an axis-aligned box, both required, min < max in every component.
void read_box_corners(const Table& t, Vec3& min, Vec3& max) {
  min = t.require_vec3("min", "min = [x, y, z]");
  max = t.require_vec3("max", "max = [x, y, z]");
  for (int k = 0; k < 3; ++k) {
    if (!(min[k] < max[k])) {
      t.fail(t.line_of(*t.find("max")),
             t.key_path("max") + " = " + format_vec3(max) + " is not above " + t.key_path("min") + " = " + format_vec3(min) +
                 " in " + std::string(1, "xyz"[k]),
             "a box needs min < max in every component [m]");
    }
  }
}

void read_solver(const Table& t, SceneSolverSettings& s) {
  t.allow_only({"dt", "min_dt", "max_substep", "solver", "tolerance", "max_iterations", "preconditioner",
                "refactor_iterations", "loose_node_slots", "stiffness", "rotation", "exact_when_gaining", "exact_gain_share", "energy_halvings",
                "contact_iterations", "contact_sweeps", "rigid_resting_speed", "rigid_fragments_below", "rigid_when_gaining_below", "sleep_speed", "sleep_time", "threads", "max_splits_per_step"});
  t.read_number("dt", s.dt, [](double v) { return v > 0 && v <= 1; }, "0 < dt <= 1 [s]");
  t.read_number("min_dt", s.min_dt, [&](double v) { return v >= 0 && v <= s.dt; },
                "0 <= min_dt <= dt (= " + format_number(s.dt) + ") [s]; 0 means a fixed step");
  // The 10,000 matches sim::World's own limit, so the scene's line is named first.
  t.read_number("max_substep", s.max_substep,
                [&](double v) { return v == 0 || (v > 0 && v <= 1 && s.dt / v <= 10000); },
                "max_substep = 0 (never substep) or dt / 10000 <= max_substep <= 1 [s]");
  t.read_choice("solver", s.solver, {{"direct", SceneSolver::Direct}, {"cg", SceneSolver::ConjugateGradient}});
  t.read_number("tolerance", s.tolerance, [](double v) { return v > 0 && v < 1; }, "0 < tolerance < 1 (relative residual)");
  t.read_integer("max_iterations", s.max_iterations, 1, INT_MAX, "an integer >= 1");
  t.read_choice("preconditioner", s.preconditioner,
                {{"cholesky", ScenePreconditioner::Cholesky}, {"jacobi", ScenePreconditioner::Jacobi}});
  t.read_integer("refactor_iterations", s.refactor_iterations, 1, INT_MAX, "an integer >= 1");
  t.read_integer("loose_node_slots", s.loose_node_slots, 0, 8, "an integer in 0 … 8 (0 = none)");
  t.read_choice("stiffness", s.stiffness, {{"warped", SceneStiffness::Warped}, {"exact", SceneStiffness::Exact}});
  t.read_choice("rotation", s.rotation, {{"arc", SceneRotation::Arc}, {"line", SceneRotation::Line}});
  t.read_choice("exact_when_gaining", s.exact_when_gaining,
                {{"never", SceneExact::Never}, {"solve", SceneExact::Solve}, {"contacts", SceneExact::Contacts}});
  t.read_number("exact_gain_share", s.exact_gain_share, [](double v) { return v >= 0 && v <= 1; },
                "0 <= exact_gain_share <= 1 (0 = solve every gain again)");
  t.read_integer("energy_halvings", s.energy_halvings, 0, kMaxEnergyHalvings,
                 "an integer in 0 … " + std::to_string(kMaxEnergyHalvings) + " (0 = never)");
  t.read_integer("contact_iterations", s.contact_iterations, 1, kMaxContactIterations,
                 "an integer in 1 … " + std::to_string(kMaxContactIterations));
  t.read_integer("contact_sweeps", s.contact_sweeps, 0, kMaxContactSweeps,
                 "an integer in 0 … " + std::to_string(kMaxContactSweeps) + " (0 = always the augmented Lagrangian)");
  double resting_speed = 0;
  if (t.read_number("rigid_resting_speed", resting_speed, [](double v) { return v >= 0 && v <= 10; },
                    "0 <= rigid_resting_speed <= 10 [m/s]; 0 means every fragment stays deformable")) {
    s.rigid_resting_speed = resting_speed;
  }
  t.read_number("sleep_speed", s.sleep_speed, [](double v) { return v >= 0 && v <= 1; },
                "0 <= sleep_speed <= 1 [m/s]; 0 means nothing sleeps");
  t.read_number("sleep_time", s.sleep_time, [](double v) { return v > 0 && v <= 1e6; }, "0 < sleep_time [s]");
  t.read_integer("threads", s.threads, 0, kMaxThreads, "an integer in 0 … " + std::to_string(kMaxThreads) + " (0 = all cores)");
  t.read_integer("max_splits_per_step", s.max_splits_per_step, 0, INT_MAX, "an integer >= 0");
  t.read_integer("rigid_fragments_below", s.rigid_fragments_below, 0, 1'000'000, "an integer 0 … 1e6 (tets)");
  t.read_integer("rigid_when_gaining_below", s.rigid_when_gaining_below, 0, 1'000'000,
                 "an integer 0 … 1e6 (tets; 0 = never)");
}

void read_features(const Table& t, SceneFeatures& f) {
  t.allow_only({"fracture", "collisions", "self_collision", "collision_mode", "mass_weighting"});
  t.read_bool("fracture", f.fracture);
  t.read_bool("collisions", f.collisions);
  t.read_bool("self_collision", f.self_collision);
  t.read_choice("collision_mode", f.collision_mode,
                {{"spheres", SceneCollisionMode::Spheres}, {"vertices", SceneCollisionMode::Vertices}});
  t.read_bool("mass_weighting", f.mass_weighting);
}

void read_environment(const Table& t, Scene& scene) {
  t.allow_only({"gravity", "ground", "box", "sphere"});
  t.read_vec3("gravity", scene.gravity, kMaxGravity, "a magnitude of at most 1e4 m/s^2 (about 1,000 g)");
  if (const auto ground = t.sub_table("ground", "[environment.ground]")) {
    ground->allow_only({"normal", "offset", "restitution", "friction", "rolling_resistance"});
    SceneGround& g = scene.ground;
    g.enabled = true;
    if (ground->read_vec3("normal", g.normal)) {
      if (!(g.normal.norm() > 0)) {
        ground->fail(ground->line_of(*ground->find("normal")), ground->key_path("normal") + " = " + format_vec3(g.normal) + " is zero",
                     "the normal points out of the ground, e.g. [0, 0, 1]; any non-zero length");
      }
      g.normal.normalize();
    }
    ground->read_number("offset", g.offset, [](double v) { return std::abs(v) <= kMaxDistance; }, "|offset| <= 1e6 [m]");
    read_contact(*ground, g.restitution, g.friction, g.rolling_resistance);
  }
  for (const Table& b : t.table_array("box", "[environment.box]")) {
    b.allow_only({"min", "max", "restitution", "friction", "rolling_resistance"});
    SceneBox& box = scene.boxes.emplace_back();
    read_box_corners(b, box.min, box.max);
    read_contact(b, box.restitution, box.friction, box.rolling_resistance);
  }
  for (const Table& s : t.table_array("sphere", "[environment.sphere]")) {
    s.allow_only({"center", "radius", "restitution", "friction", "rolling_resistance"});
    SceneSphere& sphere = scene.spheres.emplace_back();
    sphere.center = s.require_vec3("center", "center = [x, y, z]");
    sphere.radius = s.require_number("radius", kPositive, "radius > 0 [m]", "radius = 0.5");
    read_contact(s, sphere.restitution, sphere.friction, sphere.rolling_resistance);
  }
}

void read_material(const Table& t, SceneMaterial& m) {
  t.allow_only({"density", "youngs_modulus", "poisson_ratio", "toughness", "rayleigh_mass", "rayleigh_stiffness",
                "restitution", "friction", "rolling_resistance"});
  t.read_number("density", m.density, kPositive, "density > 0 [kg/m^3]");
  t.read_number("youngs_modulus", m.youngs_modulus, [](double v) { return v > 0 && v <= kMaxYoungsModulus; },
                "0 < youngs_modulus <= 1e13 [Pa]");
  t.read_number("poisson_ratio", m.poisson_ratio, [](double v) { return v >= 0 && v < 0.5; }, "0 <= poisson_ratio < 0.5");
  if (const toml::node* node = t.find("toughness")) {
    // The one value that may be infinite: "inf" (or TOML's inf) means never fractures.
    const std::string path = t.key_path("toughness");
    const std::string allowed = "a number >= 0 [N], or \"inf\" for an object that never fractures";
    if (const auto* s = node->as_string()) {
      if (s->get() != "inf") t.fail(t.line_of(*node), path + " = " + show(*node) + " is not a number", allowed);
      m.toughness = std::numeric_limits<double>::infinity();
    } else if (const auto* f = node->as_floating_point(); f && std::isinf(f->get())) {
      if (f->get() < 0) t.fail(t.line_of(*node), path + " = " + show(*node) + " is out of range", "allowed: " + allowed);
      m.toughness = f->get();
    } else {
      t.read_number("toughness", m.toughness, kNonNegative, allowed);
    }
  }
  t.read_number("rayleigh_mass", m.rayleigh_mass, kNonNegative, "rayleigh_mass >= 0 [1/s]");
  t.read_number("rayleigh_stiffness", m.rayleigh_stiffness, kNonNegative, "rayleigh_stiffness >= 0 [s]");
  read_contact(t, m.restitution, m.friction, m.rolling_resistance);
}

void read_pin(const Table& t, SceneObject& object) {
  t.allow_only({"box", "nodes"});
  const toml::node* box_node = t.find("box");
  const toml::node* nodes_node = t.find("nodes");
  const std::string hint = "each [[object.pin]] holds either box = { min = [..], max = [..] } or nodes = [i, j, ...]";
  if (box_node && nodes_node) t.fail(t.line(), t.path() + " has both box and nodes", hint);
  if (!box_node && !nodes_node) t.fail(t.line(), t.path() + " has neither box nor nodes", hint);
  if (const auto box = t.sub_table("box", "object.pin.box")) {
    box->allow_only({"min", "max"});
    ScenePinBox& pin = object.pin_boxes.emplace_back();
    read_box_corners(*box, pin.min, pin.max);
    return;
  }
  const auto* array = nodes_node->as_array();
  if (!array) {
    t.fail(t.line_of(*nodes_node), t.key_path("nodes") + " must be an array of node indices, got " + describe_type(*nodes_node),
           "write nodes = [0, 17, 42]");
  }
  for (std::size_t i = 0; i < array->size(); ++i) {
    const toml::node& element = *array->get(i);
    const std::string path = t.key_path("nodes") + "[" + std::to_string(i) + "]";
    const std::int64_t index = t.integer_at(element, path);
    if (index < 0 || index >= static_cast<std::int64_t>(kInvalidIndex)) {
      t.fail(t.line_of(element), path + " = " + show(element) + " is out of range",
             "node indices are 0-based cage node numbers, >= 0");
    }
    object.pin_nodes.push_back(static_cast<Index>(index));
  }
}

/// An optional colour: three numbers in [0, 1].
void read_color(const Table& t, std::string_view key, std::optional<Vec3>& out) {
  Vec3 color;
  if (!t.read_vec3(key, color)) return;
  if ((color.array() < 0.0).any() || (color.array() > 1.0).any()) {
    t.fail(t.line_of(*t.find(key)), t.key_path(key) + " = " + format_vec3(color) + " is not a colour",
           "give linear red, green and blue from 0 to 1, e.g. [0.8, 0.45, 0.36]");
  }
  out = color;
}

void read_object(const Table& t, const std::filesystem::path& folder, SceneObject& object) {
  t.allow_only({"name", "bundle", "translation", "rotation", "scale", "velocity", "angular_velocity", "material", "pin",
                "color", "interior_color"});
  object.line = t.line();
  const auto bundle = t.read_string("bundle");
  if (!bundle) t.fail_missing("bundle", "bundle = \"path/to/asset.h5\"");
  if (bundle->empty()) t.fail(t.line_of(*t.find("bundle")), t.key_path("bundle") + " is empty", "the path of a bundle written by fissure-bake");
  const std::filesystem::path path(*bundle);
  object.bundle = path.is_absolute() ? path : (folder / path).lexically_normal();
  object.name = t.read_string("name").value_or(path.stem().string());
  t.read_vec3("translation", object.translation, kMaxDistance, kPositionRange);
  if (const auto rotation = t.sub_table("rotation", "object.rotation")) {
    rotation->allow_only({"axis", "degrees"});
    rotation->read_number("degrees", object.rotation_degrees, [](double) { return true; }, "any finite angle [degrees]");
    if (rotation->read_vec3("axis", object.rotation_axis)) {
      if (object.rotation_axis.norm() > 0) {
        object.rotation_axis.normalize();
      } else if (object.rotation_degrees != 0) {
        rotation->fail(rotation->line_of(*rotation->find("axis")),
                       rotation->key_path("axis") + " = " + format_vec3(object.rotation_axis) + " is zero",
                       "a rotation by a non-zero angle needs a non-zero axis, e.g. [0, 0, 1]");
      } else {
        object.rotation_axis = Vec3::UnitZ();
      }
    }
  }
  t.read_number("scale", object.scale, kPositive, "scale > 0 (uniform)");
  t.read_vec3("velocity", object.velocity, kMaxSpeed, kSpeedRange);
  t.read_vec3("angular_velocity", object.angular_velocity, kMaxAngularSpeed, "at most 1e4 rad/s");
  if (const auto material = t.sub_table("material", "[object.material]")) read_material(*material, object.material);
  for (const Table& pin : t.table_array("pin", "[object.pin]")) read_pin(pin, object);
  read_color(t, "color", object.color);
  read_color(t, "interior_color", object.interior_color);
}

void read_camera(const Table& t, SceneCamera& c) {
  t.allow_only({"position", "target", "fov", "up"});
  c.line = t.line();
  c.position = t.require_vec3("position", "position = [x, y, z]");
  c.target = t.require_vec3("target", "target = [x, y, z]");
  if ((c.target - c.position).norm() <= 0) {
    t.fail(t.line_of(*t.find("target")), t.key_path("target") + " is the camera's position", "look at another point");
  }
  t.read_number("fov", c.fov_degrees, [](double v) { return v > 1 && v < 170; }, "fov between 1 and 170 [degrees, vertical]");
  Vec3 up;
  if (t.read_vec3("up", up)) {
    if (up.norm() <= 0 || up.normalized().cross((c.target - c.position).normalized()).norm() < 1e-6) {
      t.fail(t.line_of(*t.find("up")), t.key_path("up") + " = " + format_vec3(up) + " is zero or along the view",
             "give the direction that should point up in the image, e.g. [0, 0, 1]");
    }
    c.up = up.normalized();
  }
}

void read_projectile(const Table& t, SceneProjectile& p) {
  t.allow_only({"radius", "mass", "position", "velocity", "launch_time", "restitution", "friction", "rolling_resistance"});
  p.line = t.line();
  p.radius = t.require_number("radius", kPositive, "radius > 0 [m]", "radius = 0.05");
  p.mass = t.require_number("mass", kPositive, "mass > 0 [kg]", "mass = 1.0");
  if (!t.read_vec3("position", p.position, kMaxDistance, kPositionRange)) t.fail_missing("position", "position = [x, y, z]");
  if (!t.read_vec3("velocity", p.velocity, kMaxSpeed, kSpeedRange)) t.fail_missing("velocity", "velocity = [vx, vy, vz]");
  t.read_number("launch_time", p.launch_time, kNonNegative, "launch_time >= 0 [s]");
  read_contact(t, p.restitution, p.friction, p.rolling_resistance);
}

}  // namespace

Scene parse_scene(std::string_view text, const std::filesystem::path& file_for_messages) {
  const std::string file = file_for_messages.string();
  toml::table root;
  try {
    root = toml::parse(text, file);
  } catch (const toml::parse_error& e) {
    const auto& begin = e.source().begin;
    throw Error(file + ":" + std::to_string(begin.line) + ":" + std::to_string(begin.column) +
                    ": TOML syntax error: " + std::string(e.description()),
                "see docs/scene-example.toml for the layout and https://toml.io for the syntax");
  }

  const Source source(file);
  const Table top(source, root, "", "", 1);
  top.allow_only({"solver", "features", "environment", "object", "projectile", "camera"});

  Scene scene;
  scene.file = file_for_messages;
  if (const auto solver = top.sub_table("solver", "[solver]")) read_solver(*solver, scene.solver);
  if (const auto features = top.sub_table("features", "[features]")) read_features(*features, scene.features);
  if (const auto environment = top.sub_table("environment", "[environment]")) read_environment(*environment, scene);
  const std::filesystem::path folder = file_for_messages.parent_path();
  for (const Table& object : top.table_array("object", "[object]")) read_object(object, folder, scene.objects.emplace_back());
  if (scene.objects.empty()) {
    source.fail(1, "object: the scene has no [[object]]", "add at least one [[object]] section with bundle = \"path/to/asset.h5\"");
  }
  for (const Table& projectile : top.table_array("projectile", "[projectile]")) read_projectile(projectile, scene.projectiles.emplace_back());
  if (const auto camera = top.sub_table("camera", "[camera]")) read_camera(*camera, scene.camera.emplace());
  return scene;
}

Scene read_scene(const std::filesystem::path& file) {
  // A scene is text; 64 MiB holds a million bodies' worth, and /dev/zero is refused.
  return parse_scene(read_input_file(file, std::uint64_t{64} << 20), file);
}

}  // namespace fissure::formats
