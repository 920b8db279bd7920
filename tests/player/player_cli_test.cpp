// End-to-end tests of the fissure-player executable: a scene over a real bundle file,
// its report and trajectory, and the errors a user meets.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "formats/bundle.h"
#include "formats/image.h"
#include "tests/support/run_command.h"
#include "tests/support/temp_dir.h"
#include "tests/support/two_tet_bundle.h"

namespace fissure {
namespace {

using testing::quoted;

testing::CommandResult player(const std::string& arguments) {
  return testing::run_command(std::string(FISSURE_PLAYER_EXE) + " " + arguments);
}

std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path);
  return {std::istreambuf_iterator<char>(in), {}};
}

/// A two-tet bundle (no collision stage: the player falls back to inscribed spheres)
/// resting 0.5 m above the ground, with the scene text after `[[object]]` appended.
class PlayerCli : public ::testing::Test {
 protected:
  void SetUp() override { formats::write_bundle(dir.path() / "two.h5", testing::two_tet_bundle()); }

  std::filesystem::path scene(const std::string& extra_object_keys, const std::string& tail = "") {
    const std::filesystem::path path = dir.path() / "scene.toml";
    std::ofstream(path) << "[solver]\ndt = 0.004\n\n[environment.ground]\n\n[[object]]\nbundle = \"two.h5\"\n"
                           "translation = [0, 0, 0.5]\n"
                        << extra_object_keys << "\n" << tail;
    return path;
  }

  testing::TempDir dir;
};

TEST_F(PlayerCli, RunsHeadlessAndWritesReportAndTrajectory) {
  const auto report = dir.path() / "report.json", trajectory = dir.path() / "trajectory.h5";
  const auto result = player("run " + quoted(scene("")) + " --no-render --steps 250 --report " + quoted(report) +
                             " --trajectory " + quoted(trajectory) + " --trajectory-every 50");
  ASSERT_EQ(result.exit_code, 0) << result.output;
  for (const char* phase : {"forces", "assembly", "solve", "fracture", "collisions", "guard"}) {
    EXPECT_NE(result.output.find(phase), std::string::npos) << phase;
  }
  const std::string json = read_text(report);
  for (const char* key : {"\"timings\"", "\"energy_final_J\"", "\"linear_momentum_final\"", "\"fragments\"",
                          "\"sphere_penetration_max_m\"", "\"vertex_penetration_max_m\"", "\"no_tunnelling\""}) {
    EXPECT_NE(json.find(key), std::string::npos) << key;
  }
  EXPECT_TRUE(std::filesystem::exists(trajectory));
  EXPECT_NE(result.output.find("(6 frames)"), std::string::npos) << result.output;  // steps 0, 50, …, 250
  // No temporary files are left beside the outputs.
  for (const auto& entry : std::filesystem::directory_iterator(dir.path())) {
    EXPECT_EQ(entry.path().string().find(".tmp"), std::string::npos) << entry.path();
  }
}

/// The integer after "key": in a JSON text (the report's flat summary fields).
long json_integer(const std::string& json, const std::string& key) {
  const std::size_t at = json.find("\"" + key + "\":");
  return at == std::string::npos ? -1 : std::stol(json.substr(at + key.size() + 3));
}

// Issue 42: a line per step, to find what made a step slow; its columns add up to the
// report's totals.
TEST_F(PlayerCli, StepLogHasALinePerStepThatAddsUpToTheReport) {
  const auto report = dir.path() / "report.json", log = dir.path() / "steps.csv";
  const auto result = player("run " + quoted(scene("")) + " --no-render --steps 250 --report " + quoted(report) +
                             " --step-log " + quoted(log));
  ASSERT_EQ(result.exit_code, 0) << result.output;
  EXPECT_NE(result.output.find("step log   " + log.string()), std::string::npos) << result.output;
  std::ifstream in(log);
  std::string line;
  ASSERT_TRUE(std::getline(in, line));
  EXPECT_EQ(line.rfind("step,time_s,step_ms,forces_ms,", 0), 0u) << line;
  const auto columns = static_cast<std::size_t>(std::count(line.begin(), line.end(), ',') + 1);
  std::map<std::string, std::size_t> column;
  {
    std::istringstream names(line);
    for (std::string name; std::getline(names, name, ',');) column.emplace(name, column.size());
  }
  long steps = 0, contacts = 0, factorizations = 0;
  while (std::getline(in, line)) {
    std::vector<double> values;
    std::istringstream fields(line);
    for (std::string field; std::getline(fields, field, ',');) values.push_back(std::stod(field));
    ASSERT_EQ(values.size(), columns) << line;
    ++steps;
    EXPECT_EQ(values[column.at("step")], static_cast<double>(steps));
    EXPECT_NEAR(values[column.at("time_s")], 0.004 * static_cast<double>(steps), 1e-9);
    // The phases are disjoint parts of the step (each rounded to 0.1 µs in the log).
    double phases = 0.0;
    for (const char* phase : {"forces_ms", "assembly_ms", "solve_ms", "fracture_ms", "collisions_ms", "guard_ms"}) {
      phases += values[column.at(phase)];
    }
    EXPECT_LE(phases, values[column.at("step_ms")] + 6e-4) << line;
    contacts += std::lround(values[column.at("contacts")]);
    factorizations += std::lround(values[column.at("factorizations")]);
  }
  EXPECT_EQ(steps, 250);
  const std::string json = read_text(report);
  EXPECT_GT(contacts, 0) << "the tets should have landed";
  EXPECT_EQ(contacts, json_integer(json, "contacts"));
  EXPECT_EQ(factorizations, json_integer(json, "factorizations"));
}

TEST_F(PlayerCli, WithoutFramesOrVideoItMakesNoImages) {
  const auto result = player("run " + quoted(scene("")) + " --steps 5");
  EXPECT_EQ(result.exit_code, 0) << result.output;
  EXPECT_EQ(result.output.find("frames "), std::string::npos) << result.output;
  EXPECT_EQ(result.output.find("rendering"), std::string::npos) << result.output;  // no GL context either
}

// 0.5 s at 1/0.004 s steps, 20 frames per second: frames at t = 0, 0.05, …, 0.5.
TEST_F(PlayerCli, FramesAndVideoComeAtTheirOwnRateWithARecordPerFrame) {
  const auto frames = dir.path() / "frames", video = dir.path() / "drop.mp4";
  const auto result = player("run " + quoted(scene("")) + " --steps 125 --fps 20 --size 64x48 --frames " +
                             quoted(frames) + " --video " + quoted(video));
  ASSERT_EQ(result.exit_code, 0) << result.output;
  for (int f = 0; f <= 10; ++f) {
    char name[32];
    std::snprintf(name, sizeof name, "frame-%05d.png", f);
    const formats::Image image = formats::read_png(frames / name);
    EXPECT_EQ(image.width, 64);
    EXPECT_EQ(image.height, 48);
  }
  EXPECT_FALSE(std::filesystem::exists(frames / "frame-00011.png"));
  const std::string records = read_text(frames / "frames.json");
  for (const char* key : {"\"render_ms\"", "\"physics_ms\"", "\"upload_bytes\"", "\"renderer\""}) {
    EXPECT_NE(records.find(key), std::string::npos) << key;
  }
  EXPECT_GT(std::filesystem::file_size(video), 0u);
  EXPECT_NE(result.output.find("frames     11 at 20/s"), std::string::npos) << result.output;
}

// Every view option draws without a GL error (the renderer checks after each frame),
// and each changes the image.
TEST_F(PlayerCli, DebugViewsAndToggledFeaturesRender) {
  const auto frame = [&](const std::string& options, const std::string& name) {
    const auto folder = dir.path() / name;
    const auto result = player("run " + quoted(scene("")) + " --steps 1 --fps 1 --size 64x48 --frames " + quoted(folder) + " " + options);
    EXPECT_EQ(result.exit_code, 0) << options << "\n" << result.output;
    return formats::read_png(folder / "frame-00000.png").rgba;
  };
  const auto plain = frame("", "plain");
  for (const char* options : {"--cage", "--fragment-colors", "--spheres", "--replication-colors"}) EXPECT_NE(frame(options, "view"), plain) << options;
  for (const char* options : {"--no-walls", "--no-normal-mapping", "--tessellation 0", "--tessellation 64", "--backend egl"}) {
    EXPECT_EQ(frame(options, "same"), plain) << options << ": nothing is broken open at rest, and EGL draws as OSMesa";
  }
}

TEST_F(PlayerCli, ImageOptionsThatCannotWorkAreErrors) {
  auto result = player("run " + quoted(scene("")) + " --no-render --frames " + quoted(dir.path() / "f"));
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.output.find("--no-render contradicts"), std::string::npos) << result.output;
  result = player("run " + quoted(scene("")) + " --size 12x7000000 --frames " + quoted(dir.path() / "f"));
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.output.find("--size"), std::string::npos) << result.output;
  result = player("run " + quoted(scene("")) + " --backend vulkan --frames " + quoted(dir.path() / "f"));
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.output.find("osmesa"), std::string::npos) << result.output;
}

TEST_F(PlayerCli, SceneErrorsNameTheFileLineAndKey) {
  const auto result = player("run " + quoted(scene("youngs_modulus = 3")) + " --no-render --steps 1");
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.output.find("scene.toml:9"), std::string::npos) << result.output;
  EXPECT_NE(result.output.find("youngs_modulus"), std::string::npos) << result.output;
}

TEST_F(PlayerCli, MissingBundleAndBadPinsAreErrorsNamingTheObject) {
  std::ofstream(dir.path() / "missing.toml") << "[[object]]\nbundle = \"nowhere.h5\"\n";
  auto result = player("run " + quoted(dir.path() / "missing.toml") + " --no-render --steps 1");
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.output.find("missing.toml:1: object[0].bundle"), std::string::npos) << result.output;

  result = player("run " + quoted(scene("[[object.pin]]\nnodes = [7]")) + " --no-render --steps 1");
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.output.find("pinned node 7 does not exist"), std::string::npos) << result.output;
}

// A run whose numbers stop being finite ends with exit 1 and a message naming the step
// and the time, and still leaves its report (which records why) and trajectory.
// A speed whose energy overflows a double (½mv² at 1e200 m/s) used to run until the
// energy became non-finite, with no key to change; the reader now names the key.
TEST_F(PlayerCli, AnOverflowingSpeedIsRejectedNamingTheSceneKey) {
  const std::filesystem::path path = dir.path() / "blowup.toml";
  std::ofstream(path) << "[solver]\ndt = 0.01\n\n[[object]]\nbundle = \"two.h5\"\nvelocity = [1e200, 0, 0]\n";
  const auto report = dir.path() / "report.json";
  const auto result = player("run " + quoted(path) + " --no-render --steps 10 --report " + quoted(report));
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("blowup.toml:6: object[0].velocity = [1e+200, 0, 0] is out of range"), std::string::npos)
      << result.output;
  EXPECT_NE(result.output.find("hint: allowed: a speed of at most 1e4 m/s"), std::string::npos) << result.output;
  EXPECT_FALSE(std::filesystem::exists(report));
}

// A run that creates energy (a steel-stiff pair of tets dropped at dt = 0.5 s: 3e8 J
// from 2,289 J in one step, as measured for issue 16) ends with exit 1 naming the step,
// the body and a likely cause, and still writes its report (never exit 0 with 1e94 J).
TEST_F(PlayerCli, ARunThatCreatesEnergyStopsWithExit1AndSaysWhereAndWhy) {
  const std::filesystem::path path = dir.path() / "large-steps.toml";
  // Plain backward Euler (rotation = "line") at one step of 0.5 s (max_substep = 0, no
  // halving) stretches the stiff pair as it tips over; the pair is a chip, which the
  // guard would otherwise move rigidly (rigid_when_gaining_below).
  std::ofstream(path) << "[solver]\ndt = 0.5\nmax_substep = 0\nrotation = \"line\"\nenergy_halvings = 0\nrigid_when_gaining_below = 0\n\n[environment.ground]\n\n[[object]]\nname = \"pair\"\nbundle = \"two.h5\"\n"
                         "translation = [0, 0, 0.05]\n\n[object.material]\nyoungs_modulus = 1e12\n";
  const auto report = dir.path() / "report.json";
  auto result = player("run " + quoted(path) + " --no-render --steps 30 --report " + quoted(report));
  EXPECT_EQ(result.exit_code, 1) << result.output;
  for (const char* part : {"stopped after 1 steps: at step 1 ", "exceeds the", "body 'pair'", "likely cause: the large step", "hint:"}) {
    EXPECT_NE(result.output.find(part), std::string::npos) << part << "\n" << result.output;
  }
  EXPECT_NE(read_text(report).find("\"outcome\":\"stopped\""), std::string::npos);
  // Asked to, the same run goes on to its end and reports the gain.
  result = player("run " + quoted(path) + " --no-render --steps 30 --no-energy-check --report " + quoted(report));
  EXPECT_EQ(result.exit_code, 0) << result.output;
  EXPECT_NE(result.output.find("warning    at step 1 "), std::string::npos) << result.output;
  EXPECT_NE(read_text(report).find("\"energy_gain\":\"at step 1 "), std::string::npos);
}

TEST_F(PlayerCli, OutputsThatWouldReplaceTheSceneOrABundleFailBeforeTheRun) {
  const auto scene_file = scene(""), bundle = dir.path() / "two.h5";
  const std::string scene_text = read_text(scene_file), bundle_bytes = read_text(bundle);
  auto result = player("run " + quoted(scene_file) + " --no-render --steps 5 --report " + quoted(scene_file));
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("--report " + scene_file.string() + ": is the input"), std::string::npos) << result.output;
  result = player("run " + quoted(scene_file) + " --no-render --steps 5 --trajectory " + quoted(bundle));
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("--trajectory " + bundle.string() + ": is the input"), std::string::npos) << result.output;
  result = player("run " + quoted(scene_file) + " --no-render --steps 5 --report " + quoted(dir.path()));
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("is a directory"), std::string::npos) << result.output;
  EXPECT_NE(result.output.find("e.g. " + (dir.path() / "report.json").string()), std::string::npos) << result.output;
  EXPECT_EQ(read_text(scene_file), scene_text);
  EXPECT_EQ(read_text(bundle), bundle_bytes);
}

TEST_F(PlayerCli, AFullDiskIsExitOneWithNothingLeftBehind) {
  const auto out = dir.path() / "out";
  std::filesystem::create_directory(out);
  const auto result = testing::run_command("ulimit -f 8; exec " + std::string(FISSURE_PLAYER_EXE) + " -q run " +
                                           quoted(scene("")) + " --no-render --steps 200 --trajectory " +
                                           quoted(out / "t.h5"));
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("t.h5: cannot write: the file exceeds the size limit"), std::string::npos)
      << result.output;
  EXPECT_TRUE(std::filesystem::is_empty(out));
}

// Issue 44 (issue 14's review): a frame that cannot be written mid-run (here a PNG past
// the file-size limit) ends the run with exit 1 naming the file, and the report of the
// run up to it is still written.
TEST_F(PlayerCli, AFrameThatCannotBeWrittenStillLeavesTheReport) {
  const auto frames = dir.path() / "frames", report = dir.path() / "report.json";
  const auto result = testing::run_command("ulimit -f 16; exec " + std::string(FISSURE_PLAYER_EXE) + " -q run " +
                                           quoted(scene("")) + " --steps 50 --size 640x480 --frames " + quoted(frames) +
                                           " --report " + quoted(report));
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("frame-00000.png"), std::string::npos) << result.output;
  EXPECT_NE(read_text(report).find("\"timings\""), std::string::npos) << result.output;
}

// Issue 44 (issue 14's review): a path the system refuses is the user's error (exit 1,
// naming it), not an internal one; a video into a missing folder fails before the run.
TEST_F(PlayerCli, PathErrorsAreUserErrorsAndAVideoFolderIsCheckedFirst) {
  const std::string long_name(300, 'a');
  std::ofstream(dir.path() / "long.toml") << "[solver]\ndt = 0.004\n\n[[object]]\nbundle = \"" << long_name << ".h5\"\n";
  auto result = player("run " + quoted(dir.path() / "long.toml") + " --steps 1");
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("File name too long"), std::string::npos) << result.output;
  EXPECT_EQ(result.output.find("internal error"), std::string::npos) << result.output;
  result = player("run " + quoted(scene("")) + " --steps 50 --video " + quoted(dir.path() / "missing" / "drop.mp4"));
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("does not exist"), std::string::npos) << result.output;
  EXPECT_EQ(result.output.find("steps of"), std::string::npos) << "the run should not have started: " << result.output;
}

TEST_F(PlayerCli, ABundleThatFailsVerifyIsRefusedNamingTheSceneKeyAndTheFile) {
  formats::Bundle broken = testing::two_tet_bundle();
  broken.embedding.instance_barycentric[0](0, 0) += 0.5;  // no longer sums to one
  formats::write_bundle(dir.path() / "two.h5", broken);
  auto result = player("run " + quoted(scene("")) + " --no-render --steps 1");
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("scene.toml:6: object[0] 'two'.bundle " + (dir.path() / "two.h5").string() +
                               " fails its checks"),
            std::string::npos)
      << result.output;
  EXPECT_NE(result.output.find("barycentric-sums"), std::string::npos) << result.output;
  EXPECT_NE(result.output.find("fissure-bake verify"), std::string::npos) << result.output;
  // A transform the cage cannot survive names the object too.
  formats::write_bundle(dir.path() / "two.h5", testing::two_tet_bundle());
  result = player("run " + quoted(scene("scale = 1e300")) + " --no-render --steps 1");
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("object[0] 'two': after the scale, tet 0 has volume inf"), std::string::npos) << result.output;
}

TEST_F(PlayerCli, BadRunOptionsAreErrors) {
  const auto result = player("run " + quoted(scene("")) + " --no-render --steps -3");
  EXPECT_EQ(result.exit_code, 1);
  EXPECT_NE(result.output.find("--steps"), std::string::npos) << result.output;
}

// Issue 46: outputs that are FIFOs, devices or sockets were replaced by regular files
// (as root, --report /dev/null would replace the system's /dev/null).
TEST_F(PlayerCli, OutputsThatAreNotRegularFilesAreRefusedBeforeTheRun) {
  const auto fifo = dir.path() / "out.fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::string run = "run " + quoted(scene("")) + " --steps 5 ";
  for (const char* option : {"--report", "--step-log", "--trajectory", "--video"}) {
    const auto result = player(run + (std::string(option) == "--video" ? "" : "--no-render ") + option + " " + quoted(fifo));
    EXPECT_EQ(result.exit_code, 1) << option << "\n" << result.output;
    EXPECT_NE(result.output.find(std::string(option) + " " + fifo.string() + ": is a FIFO (named pipe), not a regular file"),
              std::string::npos)
        << result.output;
    EXPECT_EQ(result.output.find("bodies,"), std::string::npos) << "the scene loaded before the check\n" << result.output;
    EXPECT_TRUE(std::filesystem::is_fifo(fifo)) << option << " replaced the FIFO";
  }
  auto result = player(run + "--frames " + quoted(fifo));
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("is a FIFO (named pipe), not a folder"), std::string::npos) << result.output;
  // A frame the run would write over, left as a FIFO in the frames folder.
  std::filesystem::create_directory(dir.path() / "frames");
  ASSERT_EQ(::mkfifo((dir.path() / "frames" / "frames.json").c_str(), 0600), 0);
  result = player(run + "--frames " + quoted(dir.path() / "frames"));
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("frames.json: is a FIFO"), std::string::npos) << result.output;
  EXPECT_TRUE(std::filesystem::is_fifo(dir.path() / "frames" / "frames.json"));
}

TEST_F(PlayerCli, ScenesAndBundlesThatAreStreamsOrDevicesAreRefused) {
  // A scene that is /dev/zero read until memory ran out (exit 2 after ~18 s).
  std::filesystem::create_symlink("/dev/zero", dir.path() / "zero.toml");
#if defined(__SANITIZE_ADDRESS__)
  const std::string limit;  // ASan reserves terabytes of address space at start
#else
  const std::string limit = "ulimit -v 3145728; ";
#endif
  auto result = testing::run_command(limit + "exec timeout 30 " + std::string(FISSURE_PLAYER_EXE) + " run " +
                                     quoted(dir.path() / "zero.toml") + " --no-render --steps 1");
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("zero.toml: is a character device, not a regular file"), std::string::npos) << result.output;
  ASSERT_EQ(::mkfifo((dir.path() / "fifo.h5").c_str(), 0600), 0);
  const auto path = dir.path() / "fifo-scene.toml";
  std::ofstream(path) << "[[object]]\nbundle = \"fifo.h5\"\n";
  result = testing::run_command("exec timeout 30 " + std::string(FISSURE_PLAYER_EXE) + " run " + quoted(path) +
                                " --no-render --steps 1");
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("fifo.h5: is a FIFO (named pipe), not a regular file"), std::string::npos) << result.output;
}

TEST_F(PlayerCli, ScenesWithThousandsOfEntriesAreRefusedWithTheCountAndTheLimit) {
  // 1,001 overlapping objects ran out of memory within two steps; 1,000 projectiles or
  // 100,000 boxes took over 20 s for 40 steps.
  std::string objects;
  for (int i = 0; i < 256; ++i) objects += "[[object]]\nbundle = \"two.h5\"\n";
  auto result = player("run " + quoted(scene("", objects)) + " --no-render --steps 1");
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("object: 257 [[object]] sections, more than the 256 a scene may hold"), std::string::npos)
      << result.output;
  std::string boxes;
  for (int i = 0; i < 4097; ++i) boxes += "[[environment.box]]\nmin = [0, 0, 0]\nmax = [1, 1, 1]\n";
  result = player("run " + quoted(scene("", boxes)) + " --no-render --steps 1");
  EXPECT_EQ(result.exit_code, 1) << result.output;
  EXPECT_NE(result.output.find("4097 [[environment.box]] sections, more than the 4096"), std::string::npos)
      << result.output;
}

TEST_F(PlayerCli, NonFiniteFlagsAreUsageErrors) {
  for (const char* flag : {"--tessellation nan", "--tessellation inf", "--tessellation -nan"}) {
    const auto result = player("run " + quoted(scene("")) + " --steps 1 --no-render " + flag);
    EXPECT_EQ(result.exit_code, 1) << flag << "\n" << result.output;
    // NaN passes CLI11's range check (comparisons with NaN are false); inf does not.
    const bool nan = std::string(flag).find("nan") != std::string::npos;
    EXPECT_NE(result.output.find(nan ? "is not a finite number" : "not in range"), std::string::npos) << result.output;
  }
}

}  // namespace
}  // namespace fissure
