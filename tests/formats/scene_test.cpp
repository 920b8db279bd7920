#include "formats/scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "common/error.h"
#include "tests/support/temp_dir.h"

namespace fissure::formats {
namespace {

using testing::expect_error_containing;
using testing::TempDir;

Scene parse(const std::string& text) { return parse_scene(text, "scene.toml"); }

/// A minimal valid scene (lines 1–2); `tail` starts on line 3.
std::string with_object(const std::string& tail) { return "[[object]]\nbundle = \"a.h5\"\n" + tail; }

void expect_parse_error(const std::string& text, std::initializer_list<std::string> needles) {
  SCOPED_TRACE(text);
  expect_error_containing([&] { parse(text); }, needles);
}

constexpr const char* kFullScene = R"([solver]
dt = 0.01
min_dt = 0.001
max_substep = 0.002
solver = "direct"
tolerance = 1e-4
max_iterations = 50
preconditioner = "jacobi"
refactor_iterations = 3
loose_node_slots = 2
stiffness = "exact"
rotation = "line"
contact_iterations = 3
contact_sweeps = 5
threads = 3
max_splits_per_step = 7
rigid_fragments_below = 9

[features]
fracture = true
collisions = false
self_collision = true
collision_mode = "vertices"
mass_weighting = false

[environment]
gravity = [1, 2, -3.5]

[environment.ground]
normal = [0, 3, 4]
offset = -0.25
restitution = 0.1
friction = 0.9
rolling_resistance = 0.05

[[environment.box]]
min = [0, 0, 0]
max = [1, 2, 3]
restitution = 0.3
friction = 0.4

[[environment.box]]
min = [-1, -1, -1]
max = [0, 0, 0]

[[environment.sphere]]
center = [5, 6, 7]
radius = 0.5
restitution = 0.6
friction = 0.7

[[object]]
name = "bunny"
bundle = "assets/bunny.h5"
translation = [1, 2, 3]
rotation = { axis = [0, 2, 0], degrees = 90 }
scale = 2.5
velocity = [0.5, 0, 0]
angular_velocity = [0, 0, 6.28]

[object.material]
density = 500
youngs_modulus = 2.5e7
poisson_ratio = 0.45
toughness = 1234.5
rayleigh_mass = 0.1
rayleigh_stiffness = 0.002
restitution = 0.05
friction = 1.5
rolling_resistance = 0.3

[[object.pin]]
box = { min = [-1, -1, 0], max = [1, 1, 0.1] }

[[object.pin]]
nodes = [3, 1, 4]

[[object.pin]]
nodes = [15]

[[object]]
bundle = "other/cube.h5"

[[projectile]]
radius = 0.05
mass = 2
position = [0, -3, 1]
velocity = [0, 20, 0]
launch_time = 1.5
restitution = 0.8
friction = 0.1
)";

TEST(SceneReader, ReadsEveryField) {
  const Scene scene = parse_scene(kFullScene, "scenes/full.toml");
  EXPECT_EQ(scene.file, std::filesystem::path("scenes/full.toml"));

  EXPECT_EQ(scene.solver.dt, 0.01);
  EXPECT_EQ(scene.solver.min_dt, 0.001);
  EXPECT_EQ(scene.solver.max_substep, 0.002);
  EXPECT_EQ(scene.solver.solver, SceneSolver::Direct);
  EXPECT_EQ(scene.solver.tolerance, 1e-4);
  EXPECT_EQ(scene.solver.max_iterations, 50);
  EXPECT_EQ(scene.solver.preconditioner, ScenePreconditioner::Jacobi);
  EXPECT_EQ(scene.solver.refactor_iterations, 3);
  EXPECT_EQ(scene.solver.loose_node_slots, 2);
  EXPECT_EQ(scene.solver.stiffness, SceneStiffness::Exact);
  EXPECT_EQ(scene.solver.rotation, SceneRotation::Line);
  EXPECT_EQ(scene.solver.contact_iterations, 3);
  EXPECT_EQ(scene.solver.contact_sweeps, 5);
  EXPECT_EQ(scene.solver.threads, 3);
  EXPECT_EQ(scene.solver.max_splits_per_step, 7);
  EXPECT_EQ(scene.solver.rigid_fragments_below, 9);

  EXPECT_TRUE(scene.features.fracture);
  EXPECT_FALSE(scene.features.collisions);
  EXPECT_TRUE(scene.features.self_collision);
  EXPECT_EQ(scene.features.collision_mode, SceneCollisionMode::Vertices);
  EXPECT_FALSE(scene.features.mass_weighting);

  EXPECT_EQ(scene.gravity, Vec3(1, 2, -3.5));
  EXPECT_TRUE(scene.ground.enabled);
  EXPECT_TRUE(scene.ground.normal.isApprox(Vec3(0, 0.6, 0.8)));
  EXPECT_EQ(scene.ground.offset, -0.25);
  EXPECT_EQ(scene.ground.restitution, 0.1);
  EXPECT_EQ(scene.ground.friction, 0.9);
  EXPECT_EQ(scene.ground.rolling_resistance, 0.05);

  ASSERT_EQ(scene.boxes.size(), 2u);
  EXPECT_EQ(scene.boxes[0].min, Vec3(0, 0, 0));
  EXPECT_EQ(scene.boxes[0].max, Vec3(1, 2, 3));
  EXPECT_EQ(scene.boxes[0].restitution, 0.3);
  EXPECT_EQ(scene.boxes[0].friction, 0.4);
  EXPECT_EQ(scene.boxes[1].min, Vec3(-1, -1, -1));
  EXPECT_EQ(scene.boxes[1].restitution, 0.2);
  EXPECT_EQ(scene.boxes[1].friction, 0.5);
  EXPECT_EQ(scene.boxes[1].rolling_resistance, kDefaultRollingResistance);

  ASSERT_EQ(scene.spheres.size(), 1u);
  EXPECT_EQ(scene.spheres[0].center, Vec3(5, 6, 7));
  EXPECT_EQ(scene.spheres[0].radius, 0.5);
  EXPECT_EQ(scene.spheres[0].restitution, 0.6);
  EXPECT_EQ(scene.spheres[0].friction, 0.7);

  ASSERT_EQ(scene.objects.size(), 2u);
  const SceneObject& bunny = scene.objects[0];
  EXPECT_EQ(bunny.name, "bunny");
  EXPECT_EQ(bunny.bundle, std::filesystem::path("scenes/assets/bunny.h5"));
  EXPECT_EQ(bunny.translation, Vec3(1, 2, 3));
  EXPECT_EQ(bunny.rotation_axis, Vec3(0, 1, 0));
  EXPECT_EQ(bunny.rotation_degrees, 90);
  EXPECT_EQ(bunny.scale, 2.5);
  EXPECT_EQ(bunny.velocity, Vec3(0.5, 0, 0));
  EXPECT_EQ(bunny.angular_velocity, Vec3(0, 0, 6.28));
  EXPECT_EQ(bunny.material.density, 500);
  EXPECT_EQ(bunny.material.youngs_modulus, 2.5e7);
  EXPECT_EQ(bunny.material.poisson_ratio, 0.45);
  EXPECT_EQ(bunny.material.toughness, 1234.5);
  EXPECT_EQ(bunny.material.rayleigh_mass, 0.1);
  EXPECT_EQ(bunny.material.rayleigh_stiffness, 0.002);
  EXPECT_EQ(bunny.material.restitution, 0.05);
  EXPECT_EQ(bunny.material.friction, 1.5);
  EXPECT_EQ(bunny.material.rolling_resistance, 0.3);
  ASSERT_EQ(bunny.pin_boxes.size(), 1u);
  EXPECT_EQ(bunny.pin_boxes[0].min, Vec3(-1, -1, 0));
  EXPECT_EQ(bunny.pin_boxes[0].max, Vec3(1, 1, 0.1));
  EXPECT_EQ(bunny.pin_nodes, (std::vector<Index>{3, 1, 4, 15}));
  EXPECT_EQ(bunny.line, 52);

  const SceneObject& cube = scene.objects[1];
  EXPECT_EQ(cube.name, "cube");  // the bundle's stem when no name is given
  EXPECT_EQ(cube.bundle, std::filesystem::path("scenes/other/cube.h5"));
  EXPECT_EQ(cube.line, 81);

  ASSERT_EQ(scene.projectiles.size(), 1u);
  const SceneProjectile& p = scene.projectiles[0];
  EXPECT_EQ(p.radius, 0.05);
  EXPECT_EQ(p.mass, 2);
  EXPECT_EQ(p.position, Vec3(0, -3, 1));
  EXPECT_EQ(p.velocity, Vec3(0, 20, 0));
  EXPECT_EQ(p.launch_time, 1.5);
  EXPECT_EQ(p.restitution, 0.8);
  EXPECT_EQ(p.friction, 0.1);
  EXPECT_EQ(p.line, 84);
}

// The keys that no shipped scene sets (issue 47: every key is set by a shipped or a test
// scene): the opt-in sleeping, the exact re-solve's modes, colours, and the rolling
// resistance of boxes, spheres and projectiles. Each must reach the scene as written.
TEST(SceneReader, ReadsTheKeysNoShippedSceneSets) {
  const Scene scene = parse(R"([solver]
exact_when_gaining = "contacts"
exact_gain_share = 0.01
sleep_speed = 0.02
sleep_time = 0.5

[[environment.box]]
min = [0, 0, 0]
max = [1, 1, 1]
rolling_resistance = 0.1

[[environment.sphere]]
center = [3, 0, 0]
radius = 0.5
rolling_resistance = 0.2

[[object]]
bundle = "a.h5"
color = [0.1, 0.2, 0.3]
interior_color = [0.9, 0.5, 0.25]

[[projectile]]
radius = 0.05
mass = 1
position = [0, -3, 0.5]
velocity = [0, 10, 0]
rolling_resistance = 0.3
)");
  EXPECT_EQ(scene.solver.exact_when_gaining, SceneExact::Contacts);
  EXPECT_EQ(scene.solver.exact_gain_share, 0.01);
  EXPECT_EQ(scene.solver.sleep_speed, 0.02);
  EXPECT_EQ(scene.solver.sleep_time, 0.5);
  ASSERT_EQ(scene.boxes.size(), 1u);
  EXPECT_EQ(scene.boxes[0].rolling_resistance, 0.1);
  ASSERT_EQ(scene.spheres.size(), 1u);
  EXPECT_EQ(scene.spheres[0].rolling_resistance, 0.2);
  ASSERT_EQ(scene.objects.size(), 1u);
  EXPECT_EQ(scene.objects[0].color, Vec3(0.1, 0.2, 0.3));
  EXPECT_EQ(scene.objects[0].interior_color, Vec3(0.9, 0.5, 0.25));
  ASSERT_EQ(scene.projectiles.size(), 1u);
  EXPECT_EQ(scene.projectiles[0].rolling_resistance, 0.3);
  EXPECT_EQ(parse(with_object("[solver]\nexact_when_gaining = \"never\"\n")).solver.exact_when_gaining, SceneExact::Never);
  expect_parse_error(with_object("[solver]\nsleep_time = 0\n"), {"solver.sleep_time"});
  expect_parse_error(with_object("[solver]\nsleep_speed = -1\n"), {"solver.sleep_speed"});
}

TEST(SceneReader, DefaultsApply) {
  const Scene scene = parse(with_object(""));
  EXPECT_EQ(scene.solver.dt, 1.0 / 240);
  EXPECT_EQ(scene.solver.min_dt, 0);
  EXPECT_EQ(scene.solver.solver, SceneSolver::ConjugateGradient);
  EXPECT_EQ(scene.solver.tolerance, 1e-4);
  EXPECT_EQ(scene.solver.max_iterations, 500);
  EXPECT_EQ(scene.solver.preconditioner, ScenePreconditioner::Cholesky);
  EXPECT_EQ(scene.solver.stiffness, SceneStiffness::Warped);
  EXPECT_EQ(scene.solver.contact_iterations, 8);
  EXPECT_EQ(scene.solver.contact_sweeps, 16);
  EXPECT_FALSE(scene.solver.rigid_resting_speed.has_value());
  EXPECT_EQ(rigid_resting_speed(scene), kRestingSpeedUnbreakable);  // nothing breaks without fracture
  EXPECT_EQ(scene.solver.rigid_fragments_below, 0);
  EXPECT_EQ(scene.solver.rigid_when_gaining_below, 8);
  EXPECT_EQ(scene.solver.threads, 0);
  EXPECT_EQ(scene.solver.max_splits_per_step, 64);
  EXPECT_FALSE(scene.features.fracture);
  EXPECT_TRUE(scene.features.collisions);
  EXPECT_FALSE(scene.features.self_collision);
  EXPECT_EQ(scene.features.collision_mode, SceneCollisionMode::Spheres);
  EXPECT_TRUE(scene.features.mass_weighting);
  EXPECT_EQ(scene.gravity, Vec3(0, 0, -9.81));
  EXPECT_FALSE(scene.ground.enabled);
  EXPECT_TRUE(scene.boxes.empty());
  EXPECT_TRUE(scene.spheres.empty());
  EXPECT_TRUE(scene.projectiles.empty());

  ASSERT_EQ(scene.objects.size(), 1u);
  const SceneObject& o = scene.objects[0];
  EXPECT_EQ(o.name, "a");
  EXPECT_EQ(o.bundle, std::filesystem::path("a.h5"));
  EXPECT_EQ(o.translation, Vec3::Zero());
  EXPECT_EQ(o.rotation_axis, Vec3::UnitZ());
  EXPECT_EQ(o.rotation_degrees, 0);
  EXPECT_EQ(o.scale, 1);
  EXPECT_EQ(o.velocity, Vec3::Zero());
  EXPECT_EQ(o.angular_velocity, Vec3::Zero());
  EXPECT_EQ(o.material.density, 1000);
  EXPECT_EQ(o.material.youngs_modulus, 1e6);
  EXPECT_EQ(o.material.poisson_ratio, 0.3);
  EXPECT_TRUE(std::isinf(o.material.toughness));
  EXPECT_EQ(o.material.rayleigh_mass, 0);
  EXPECT_EQ(o.material.rayleigh_stiffness, 0);
  EXPECT_EQ(o.material.restitution, 0.2);
  EXPECT_EQ(o.material.friction, 0.5);
  EXPECT_TRUE(o.pin_boxes.empty());
  EXPECT_TRUE(o.pin_nodes.empty());
  EXPECT_EQ(o.line, 1);

  // An empty ground table enables the ground with its defaults.
  const Scene grounded = parse(with_object("[environment.ground]\n"));
  EXPECT_TRUE(grounded.ground.enabled);
  EXPECT_EQ(grounded.ground.normal, Vec3::UnitZ());
  EXPECT_EQ(grounded.ground.offset, 0);
  EXPECT_EQ(grounded.ground.restitution, 0.2);
  EXPECT_EQ(grounded.ground.friction, 0.5);

  const Scene thrown = parse(with_object("[[projectile]]\nradius = 1\nmass = 1\nposition = [0, 0, 0]\nvelocity = [1, 0, 0]\n"));
  ASSERT_EQ(thrown.projectiles.size(), 1u);
  EXPECT_EQ(thrown.projectiles[0].launch_time, 0);
  EXPECT_EQ(thrown.projectiles[0].restitution, 0.5);
  EXPECT_EQ(thrown.projectiles[0].friction, 0.3);
  EXPECT_EQ(thrown.projectiles[0].line, 3);
}

// A fracture scene keeps 0.5 m/s, for what a faster limit would not let break; an
// unbreakable one rests rigidly up to 1 m/s; a value the scene gives is kept either way.
TEST(SceneReader, RestingSpeedDefaultsByWhetherTheSceneCanBreak) {
  EXPECT_EQ(rigid_resting_speed(parse(with_object("[features]\nfracture = true\n"))), kRestingSpeedBreakable);
  EXPECT_EQ(rigid_resting_speed(parse(with_object("[features]\nfracture = false\n"))), kRestingSpeedUnbreakable);
  EXPECT_EQ(rigid_resting_speed(parse(with_object("[solver]\nrigid_resting_speed = 0.3\n"))), 0.3);
  EXPECT_EQ(rigid_resting_speed(parse(with_object("[solver]\nrigid_resting_speed = 0\n[features]\nfracture = true\n"))),
            0.0);
  EXPECT_LT(kRestingSpeedBreakable, kRestingSpeedUnbreakable);
}

TEST(SceneReader, AcceptsIntegersForRealsAndInfiniteToughness) {
  const Scene scene = parse(with_object("scale = 2\n[object.material]\ntoughness = inf\n[solver]\ndt = 1\nmin_dt = 1\n"));
  EXPECT_EQ(scene.objects[0].scale, 2.0);
  EXPECT_TRUE(std::isinf(scene.objects[0].material.toughness));
  EXPECT_EQ(scene.solver.dt, 1.0);
  EXPECT_EQ(scene.solver.min_dt, 1.0);
  EXPECT_TRUE(std::isinf(parse(with_object("material.toughness = \"inf\"\n")).objects[0].material.toughness));
  EXPECT_EQ(parse(with_object("material.toughness = 0\n")).objects[0].material.toughness, 0.0);
  // A zero axis is fine when there is no rotation; it falls back to +z.
  EXPECT_EQ(parse(with_object("rotation = { axis = [0, 0, 0], degrees = 0 }\n")).objects[0].rotation_axis, Vec3::UnitZ());
  // The [object.rotation] table form works too.
  const Scene rotated = parse(with_object("[object.rotation]\naxis = [3, 0, 0]\ndegrees = -45\n"));
  EXPECT_EQ(rotated.objects[0].rotation_axis, Vec3::UnitX());
  EXPECT_EQ(rotated.objects[0].rotation_degrees, -45);
}

TEST(SceneReader, DocsExampleParses) {
  const std::filesystem::path file = std::filesystem::path(FISSURE_DOCS_DIR) / "scene-example.toml";
  const Scene scene = read_scene(file);
  ASSERT_EQ(scene.objects.size(), 1u);
  EXPECT_EQ(scene.objects[0].name, "bunny");
  EXPECT_EQ(scene.objects[0].bundle, (file.parent_path() / "../out/bunny-5k.h5").lexically_normal());
  EXPECT_EQ(scene.objects[0].pin_boxes.size(), 1u);
  EXPECT_EQ(scene.objects[0].pin_nodes, (std::vector<Index>{0, 1, 2}));
  EXPECT_TRUE(scene.ground.enabled);
  EXPECT_EQ(scene.boxes.size(), 1u);
  EXPECT_EQ(scene.spheres.size(), 1u);
  EXPECT_EQ(scene.projectiles.size(), 1u);
  // The example documents the defaults, so parsing it changes nothing but placement.
  const SceneSolverSettings defaults;
  EXPECT_DOUBLE_EQ(scene.solver.dt, defaults.dt);
  EXPECT_EQ(scene.solver.max_iterations, defaults.max_iterations);
  EXPECT_TRUE(std::isinf(scene.objects[0].material.toughness));
  ASSERT_TRUE(scene.camera.has_value());
  EXPECT_EQ(scene.camera->fov_degrees, 30.0);
  EXPECT_EQ(scene.camera->up, Vec3::UnitZ());
  EXPECT_EQ(scene.objects[0].interior_color, Vec3(0.80, 0.45, 0.36));
}

TEST(SceneReader, CameraAndColoursAreCheckedWithTheirLine) {
  const Scene plain = parse(with_object(""));
  EXPECT_FALSE(plain.camera.has_value());
  EXPECT_FALSE(plain.objects[0].color.has_value());
  const Scene placed = parse(with_object("color = [1, 0, 0]\n") +
                             "\n[camera]\nposition = [0, -2, 1]\ntarget = [0, 0, 0]\nfov = 45\n");
  EXPECT_EQ(placed.objects[0].color, Vec3(1, 0, 0));
  ASSERT_TRUE(placed.camera.has_value());
  EXPECT_EQ(placed.camera->position, Vec3(0, -2, 1));
  EXPECT_EQ(placed.camera->fov_degrees, 45.0);
  EXPECT_FALSE(placed.camera->up.has_value());
  expect_parse_error(with_object("interior_color = [1.5, 0, 0]\n"), {"interior_color", "not a colour"});
  expect_parse_error(with_object("") + "\n[camera]\nposition = [0, 0, 1]\n", {"camera", "target"});
  expect_parse_error(with_object("") + "\n[camera]\nposition = [0, 0, 1]\ntarget = [0, 0, 1]\n", {"target", "position"});
  expect_parse_error(with_object("") + "\n[camera]\nposition = [0, 0, 1]\ntarget = [0, 0, 0]\nfov = 180\n", {"fov", "170"});
  expect_parse_error(with_object("") + "\n[camera]\nposition = [0, 0, 1]\ntarget = [0, 0, 0]\nup = [0, 0, 2]\n",
                     {"up", "along the view"});
}

TEST(SceneReader, BundleResolvesRelativeToTheSceneFolder) {
  TempDir dir;
  std::filesystem::create_directories(dir / "scenes");
  const auto file = dir.write("scenes/s.toml", "[[object]]\nbundle = \"../assets/a.h5\"\n[[object]]\nbundle = \"b.h5\"\n");
  const Scene scene = read_scene(file);
  EXPECT_EQ(scene.file, file);
  EXPECT_EQ(scene.objects[0].bundle, (dir.path() / "assets/a.h5").lexically_normal());
  EXPECT_EQ(scene.objects[1].bundle, (dir.path() / "scenes/b.h5").lexically_normal());
  // Absolute paths are kept as written; the reader does not check that bundles exist.
  const auto absolute = (dir.path() / "elsewhere/c.h5").string();
  EXPECT_EQ(parse_scene("[[object]]\nbundle = \"" + absolute + "\"\n", "x/s.toml").objects[0].bundle,
            std::filesystem::path(absolute));
}

TEST(SceneReader, MissingFileIsAnError) {
  TempDir dir;
  expect_error_containing([&] { read_scene(dir / "nope.toml"); }, {"nope.toml", "not found"});
}

TEST(SceneReader, SyntaxErrorNamesLineAndColumn) {
  expect_parse_error("[[object]]\nbundle = \"a.h5\"\nscale = = 2\n", {"scene.toml:3:", "TOML syntax error"});
  expect_parse_error("[solver]\ndt = 0.1\ndt = 0.2\n", {"scene.toml:3:", "dt"});
}

TEST(SceneReader, UnknownKeysAreErrorsAtEveryLevel) {
  expect_parse_error(with_object("[solvr]\n"), {"scene.toml:3:", "unknown key solvr", "did you mean 'solver'", "projectile"});
  expect_parse_error(with_object("[solver]\ndtt = 0.01\n"),
                     {"scene.toml:4:", "unknown key solver.dtt", "did you mean 'dt'", "min_dt", "max_splits_per_step"});
  expect_parse_error(with_object("[features]\nfractures = true\n"), {"scene.toml:4:", "features.fractures", "'fracture'"});
  expect_parse_error(with_object("[environment]\ngravitation = [0, 0, 1]\n"), {"scene.toml:4:", "environment.gravitation"});
  expect_parse_error(with_object("[environment.ground]\nheight = 1\n"), {"scene.toml:4:", "environment.ground.height", "offset"});
  expect_parse_error(with_object("[[environment.box]]\nmin = [0, 0, 0]\nmax = [1, 1, 1]\ncolour = 1\n"),
                     {"scene.toml:6:", "environment.box[0].colour"});
  expect_parse_error(with_object("[[environment.sphere]]\ncentre = [0, 0, 0]\nradius = 1\n"),
                     {"scene.toml:4:", "environment.sphere[0].centre", "did you mean 'center'"});
  expect_parse_error(with_object("positon = [0, 0, 0]\n"), {"scene.toml:3:", "unknown key object[0].positon"});
  expect_parse_error(with_object("rotation = { axis = [0, 0, 1], angle = 3 }\n"),
                     {"scene.toml:3:", "object[0].rotation.angle", "degrees"});
  expect_parse_error(with_object("[object.material]\nyoung = 1e6\n"),
                     {"scene.toml:4:", "object[0].material.young", "youngs_modulus"});
  expect_parse_error(with_object("[[object.pin]]\nnode = [1]\n"), {"scene.toml:4:", "object[0].pin[0].node", "'nodes'"});
  expect_parse_error(with_object("[[object.pin]]\nbox = { min = [0, 0, 0], max = [1, 1, 1], margin = 1 }\n"),
                     {"scene.toml:4:", "object[0].pin[0].box.margin"});
  expect_parse_error(with_object("[[projectile]]\nradius = 1\nmass = 1\nposition = [0, 0, 0]\nvelocity = [0, 0, 0]\nspin = 1\n"),
                     {"scene.toml:8:", "projectile[0].spin"});
  // The second object is named by its index.
  expect_parse_error(with_object("[[object]]\nbundle = \"b.h5\"\nmaterial.densty = 1\n"),
                     {"scene.toml:5:", "object[1].material.densty", "'density'"});
}

TEST(SceneReader, WrongTypesAreErrors) {
  expect_parse_error(with_object("[solver]\ndt = \"fast\"\n"), {"scene.toml:4:", "solver.dt must be a number", "string"});
  expect_parse_error(with_object("[solver]\nmax_iterations = 10.0\n"), {"scene.toml:4:", "solver.max_iterations must be an integer"});
  expect_parse_error(with_object("[solver]\nthreads = \"4\"\n"), {"scene.toml:4:", "solver.threads must be an integer"});
  expect_parse_error(with_object("[solver]\nsolver = \"lu\"\n"), {"scene.toml:4:", "solver.solver", "\"direct\", \"cg\""});
  expect_parse_error(with_object("[solver]\nstiffness = 1\n"), {"scene.toml:4:", "solver.stiffness must be a string", "\"warped\""});
  expect_parse_error(with_object("[features]\nfracture = 1\n"), {"scene.toml:4:", "features.fracture must be true or false"});
  expect_parse_error(with_object("[features]\ncollision_mode = \"mesh\"\n"),
                     {"scene.toml:4:", "features.collision_mode", "\"spheres\", \"vertices\""});
  expect_parse_error(with_object("[environment]\ngravity = [0, -9.81]\n"),
                     {"scene.toml:4:", "environment.gravity must have 3 components, got 2"});
  expect_parse_error(with_object("[environment]\ngravity = -9.81\n"), {"scene.toml:4:", "environment.gravity must be an array of 3"});
  expect_parse_error(with_object("[environment]\ngravity = [0, \"0\", 1]\n"),
                     {"scene.toml:4:", "environment.gravity[1] must be a number"});
  expect_parse_error(with_object("solver = 3\n"), {"scene.toml:3:", "object[0].solver"});  // unknown inside [[object]]
  expect_parse_error("solver = 3\n[[object]]\nbundle = \"a.h5\"\n", {"scene.toml:1:", "solver must be a table"});
  expect_parse_error("[object]\nbundle = \"a.h5\"\n", {"scene.toml:1:", "object must be an array of tables", "[[object]]"});
  expect_parse_error(with_object("[environment.box]\nmin = [0, 0, 0]\n"),
                     {"scene.toml:3:", "environment.box must be an array of tables"});
  expect_parse_error(with_object("name = 7\n"), {"scene.toml:3:", "object[0].name must be a string"});
  expect_parse_error("[[object]]\nbundle = 1\n", {"scene.toml:2:", "object[0].bundle must be a string"});
  expect_parse_error(with_object("rotation = 30\n"), {"scene.toml:3:", "object[0].rotation must be a table"});
  expect_parse_error(with_object("[object.material]\ntoughness = \"high\"\n"),
                     {"scene.toml:4:", "object[0].material.toughness = \"high\" is not a number", "\"inf\""});
  expect_parse_error(with_object("[[object.pin]]\nnodes = [1, 2.5]\n"), {"scene.toml:4:", "object[0].pin[0].nodes[1] must be an integer"});
  expect_parse_error(with_object("[[object.pin]]\nnodes = 3\n"), {"scene.toml:4:", "object[0].pin[0].nodes must be an array"});
}

struct RangeCase {
  std::string tail;  ///< appended to a valid object; its first line is line 3
  std::string message;
  int line;
};

TEST(SceneReader, OutOfRangeValuesNameKeyAndLine) {
  const std::vector<RangeCase> cases = {
      {"[solver]\ndt = 0\n", "solver.dt = 0 is out of range", 4},
      {"[solver]\ndt = 1.5\n", "solver.dt = 1.5 is out of range", 4},
      {"[solver]\nmin_dt = 0.1\n", "solver.min_dt = 0.1 is out of range", 4},
      {"[solver]\ndt = 0.01\nmin_dt = -0.001\n", "solver.min_dt = -0.001 is out of range", 5},
      {"[solver]\ntolerance = 1\n", "solver.tolerance = 1 is out of range", 4},
      {"[solver]\nexact_gain_share = 1.5\n", "solver.exact_gain_share = 1.5 is out of range", 4},
      {"[solver]\ntolerance = 0\n", "solver.tolerance = 0 is out of range", 4},
      {"[solver]\nmax_iterations = 0\n", "solver.max_iterations = 0 is out of range", 4},
      {"[solver]\nrefactor_iterations = 0\n", "solver.refactor_iterations = 0 is out of range", 4},
      {"[solver]\nloose_node_slots = 9\n", "solver.loose_node_slots = 9 is out of range", 4},
      {"[solver]\nmax_iterations = 10000000000\n", "solver.max_iterations = 10000000000 is out of range", 4},
      {"[solver]\nthreads = -1\n", "solver.threads = -1 is out of range", 4},
      {"[solver]\ncontact_iterations = 0\n", "solver.contact_iterations = 0 is out of range", 4},
      {"[solver]\ncontact_iterations = 65\n", "solver.contact_iterations = 65 is out of range", 4},
      {"[solver]\ncontact_sweeps = -1\n", "solver.contact_sweeps = -1 is out of range", 4},
      {"[solver]\ncontact_sweeps = 1025\n", "solver.contact_sweeps = 1025 is out of range", 4},
      {"[solver]\nrigid_resting_speed = -0.1\n", "solver.rigid_resting_speed = -0.1 is out of range", 4},
      {"[solver]\nrigid_fragments_below = -1\n", "solver.rigid_fragments_below = -1 is out of range", 4},
      {"[solver]\nrigid_when_gaining_below = -1\n", "solver.rigid_when_gaining_below = -1 is out of range", 4},
      {"[solver]\nmax_splits_per_step = -2\n", "solver.max_splits_per_step = -2 is out of range", 4},
      {"[object.material]\ndensity = 0\n", "object[0].material.density = 0 is out of range", 4},
      {"[object.material]\nyoungs_modulus = -1e6\n", "object[0].material.youngs_modulus = -1e+06 is out of range", 4},
      {"[object.material]\nyoungs_modulus = 1e14\n", "object[0].material.youngs_modulus = 1e+14 is out of range", 4},
      {"translation = [0, 2e6, 0]\n", "object[0].translation = [0, 2e+06, 0] is out of range", 3},
      {"velocity = [1e300, 0, 0]\n", "object[0].velocity = [1e+300, 0, 0] is out of range", 3},
      {"angular_velocity = [0, 0, -2e4]\n", "object[0].angular_velocity = [0, 0, -20000] is out of range", 3},
      {"[environment]\ngravity = [0, -1e308, 0]\n", "environment.gravity = [0, -1e+308, 0] is out of range", 4},
      {"[environment.ground]\noffset = 1e300\n", "environment.ground.offset = 1e+300 is out of range", 4},
      {"[[projectile]]\nradius = 1\nmass = 1\nposition = [-1e7, 0, 0]\nvelocity = [0, 0, 0]\n", "projectile[0].position = [-1e+07, 0, 0] is out of range", 6},
      {"[[projectile]]\nradius = 1\nmass = 1\nposition = [0, 0, 0]\nvelocity = [2e4, 0, 0]\n", "projectile[0].velocity = [20000, 0, 0] is out of range", 7},
      {"[object.material]\nyoungs_modulus = inf\n", "object[0].material.youngs_modulus = inf is not finite", 4},
      {"[object.material]\npoisson_ratio = 0.5\n", "object[0].material.poisson_ratio = 0.5 is out of range", 4},
      {"[object.material]\npoisson_ratio = -0.1\n", "object[0].material.poisson_ratio = -0.1 is out of range", 4},
      {"[object.material]\ntoughness = -1\n", "object[0].material.toughness = -1 is out of range", 4},
      {"[object.material]\ntoughness = -inf\n", "object[0].material.toughness = -inf is out of range", 4},
      {"[object.material]\ntoughness = nan\n", "object[0].material.toughness = nan is not finite", 4},
      {"[object.material]\nrayleigh_mass = -0.1\n", "object[0].material.rayleigh_mass = -0.1 is out of range", 4},
      {"[object.material]\nrayleigh_stiffness = -1\n", "object[0].material.rayleigh_stiffness = -1 is out of range", 4},
      {"[object.material]\nrestitution = 1.5\n", "object[0].material.restitution = 1.5 is out of range", 4},
      {"[object.material]\nfriction = -0.5\n", "object[0].material.friction = -0.5 is out of range", 4},
      {"scale = 0\n", "object[0].scale = 0 is out of range", 3},
      {"translation = [0, nan, 0]\n", "object[0].translation[1] = nan is not finite", 3},
      {"rotation = { axis = [0, 0, 0], degrees = 10 }\n", "object[0].rotation.axis = [0, 0, 0] is zero", 3},
      {"[environment]\ngravity = [0, 0, -inf]\n", "environment.gravity[2] = -inf is not finite", 4},
      {"[environment.ground]\nnormal = [0, 0, 0]\n", "environment.ground.normal = [0, 0, 0] is zero", 4},
      {"[environment.ground]\nfriction = -1\n", "environment.ground.friction = -1 is out of range", 4},
      {"[[environment.box]]\nmin = [0, 0, 0]\nmax = [1, 0, 1]\n", "environment.box[0].max = [1, 0, 1] is not above environment.box[0].min = [0, 0, 0] in y", 5},
      {"[[environment.box]]\nmin = [0, 0, 0]\nmax = [1, 1, 1]\nrestitution = -0.1\n", "environment.box[0].restitution = -0.1 is out of range", 6},
      {"[[environment.sphere]]\ncenter = [0, 0, 0]\nradius = 0\n", "environment.sphere[0].radius = 0 is out of range", 5},
      {"[[object.pin]]\nbox = { min = [0, 0, 0], max = [0, 1, 1] }\n", "object[0].pin[0].box.max = [0, 1, 1] is not above object[0].pin[0].box.min = [0, 0, 0] in x", 4},
      {"[[object.pin]]\nnodes = [0, -1]\n", "object[0].pin[0].nodes[1] = -1 is out of range", 4},
      {"[[projectile]]\nradius = 0\nmass = 1\nposition = [0, 0, 0]\nvelocity = [0, 0, 0]\n", "projectile[0].radius = 0 is out of range", 4},
      {"[[projectile]]\nradius = 1\nmass = -1\nposition = [0, 0, 0]\nvelocity = [0, 0, 0]\n", "projectile[0].mass = -1 is out of range", 5},
      {"[[projectile]]\nradius = 1\nmass = 1\nposition = [0, 0, 0]\nvelocity = [0, 0, 0]\nlaunch_time = -1\n", "projectile[0].launch_time = -1 is out of range", 8},
      {"[[projectile]]\nradius = 1\nmass = 1\nposition = [0, 0, 0]\nvelocity = [0, 0, 0]\nrestitution = 2\n", "projectile[0].restitution = 2 is out of range", 8},
  };
  for (const RangeCase& c : cases) {
    expect_parse_error(with_object(c.tail), {"scene.toml:" + std::to_string(c.line) + ": " + c.message, "hint:"});
  }
  // The hint says what is allowed.
  expect_parse_error(with_object("[object.material]\npoisson_ratio = 0.5\n"), {"0 <= poisson_ratio < 0.5"});
}

TEST(SceneReader, MissingRequiredValuesNameTheEnclosingTable) {
  expect_parse_error("", {"scene.toml:1: object: the scene has no [[object]]"});
  expect_parse_error("[solver]\ndt = 0.01\n", {"scene.toml:1:", "no [[object]]"});
  expect_parse_error("\n[[object]]\nname = \"x\"\n", {"scene.toml:2: object[0].bundle is missing", "bundle = "});
  expect_parse_error(with_object("[[object]]\nbundle = \"\"\n"), {"scene.toml:4: object[1].bundle is empty"});
  expect_parse_error(with_object("\n[[projectile]]\nmass = 1\nposition = [0, 0, 0]\nvelocity = [0, 0, 0]\n"),
                     {"scene.toml:4: projectile[0].radius is missing"});
  expect_parse_error(with_object("[[projectile]]\nradius = 1\nmass = 1\nposition = [0, 0, 0]\n"),
                     {"scene.toml:3: projectile[0].velocity is missing"});
  expect_parse_error(with_object("[[environment.box]]\nmax = [1, 1, 1]\n"), {"scene.toml:3: environment.box[0].min is missing"});
  expect_parse_error(with_object("[[environment.sphere]]\nradius = 1\n"), {"scene.toml:3: environment.sphere[0].center is missing"});
  expect_parse_error(with_object("[[object.pin]]\n"), {"scene.toml:3: object[0].pin[0] has neither box nor nodes"});
  expect_parse_error(with_object("[[object.pin]]\nnodes = [1]\nbox = { min = [0, 0, 0], max = [1, 1, 1] }\n"),
                     {"scene.toml:3: object[0].pin[0] has both box and nodes"});
  expect_parse_error(with_object("[[object.pin]]\nbox = { min = [0, 0, 0] }\n"), {"scene.toml:4: object[0].pin[0].box.max is missing"});
}

}  // namespace
}  // namespace fissure::formats
