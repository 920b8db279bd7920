// End-to-end tests of the fissure-bake executable: exit codes, messages, outputs.
#include <gtest/gtest.h>

#include <csignal>
#include <fstream>
#include <iterator>
#include <functional>
#include <sstream>

#include "bake/collision_proxies.h"
#include "formats/bundle.h"
#include "formats/cage_io.h"
#include "tests/support/procedural.h"
#include "tests/support/run_command.h"
#include "tests/support/temp_dir.h"

namespace fissure {
namespace {

using Result = testing::CommandResult;
using testing::quoted;

Result run(const std::string& arguments) { return testing::run_command(std::string(FISSURE_BAKE_EXE) + " " + arguments); }

using testing::bytes_of;

const std::filesystem::path kMesh = testing::data_dir() / "meshes" / "bunny-5k.obj";
const std::filesystem::path kCage = testing::data_dir() / "cages" / "bunny-5k-cage-100.node";

TEST(BakeCli, BakeInspectVerify) {
  testing::TempDir dir;
  const auto bundle = dir / "b.h5";
  const Result bake = run("bake --mesh " + quoted(kMesh) + " --cage " + quoted(kCage) + " -o " + quoted(bundle));
  ASSERT_EQ(bake.exit_code, 0) << bake.output;
  EXPECT_NE(bake.output.find("5000 triangles in 100 tets"), std::string::npos) << bake.output;

  const Result verify = run("verify " + quoted(bundle));
  EXPECT_EQ(verify.exit_code, 0) << verify.output;
  EXPECT_NE(verify.output.find("all invariants hold"), std::string::npos);
  EXPECT_EQ(verify.output.find("FAIL"), std::string::npos);

  const Result json = run("inspect --json " + quoted(bundle));
  EXPECT_EQ(json.exit_code, 0);
  EXPECT_NE(json.output.find("\"cage_tets\":100"), std::string::npos) << json.output;
  EXPECT_NE(json.output.find("\"role\":\"mesh\",\"file\":\"bunny-5k.obj\""), std::string::npos) << json.output;
}

TEST(BakeCli, SameInputsGiveIdenticalBundlesAtAnyThreadCount) {
  testing::TempDir dir;
  const std::string inputs = " --mesh " + quoted(kMesh) + " --cage " + quoted(kCage);
  ASSERT_EQ(run("-q -j 1 bake" + inputs + " -o " + quoted(dir / "a.h5")).exit_code, 0);
  ASSERT_EQ(run("-q -j 2 bake" + inputs + " -o " + quoted(dir / "b.h5")).exit_code, 0);
  EXPECT_EQ(bytes_of(dir / "a.h5"), bytes_of(dir / "b.h5"));
}

TEST(BakeCli, ErrorsExitOneNameTheFileAndWriteNothing) {
  testing::TempDir dir;
  const auto out = dir / "out.h5";
  Result r = run("bake --mesh " + quoted(dir / "missing.obj") + " --cage " + quoted(kCage) + " -o " + quoted(out));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("error: "), std::string::npos);
  EXPECT_NE(r.output.find("missing.obj: file not found"), std::string::npos) << r.output;

  // A cage far too small for the bunny.
  TetMesh small = testing::grid_cage(Vec3(-0.05, 0.05, -0.05), Vec3(0.0, 0.1, 0.0), 2, 2, 2);
  formats::write_tetgen(small, dir / "small.node", dir / "small.ele");
  r = run("bake --mesh " + quoted(kMesh) + " --cage " + quoted(dir / "small.node") + " -o " + quoted(out));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("does not cover"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("hint: enlarge the cage"), std::string::npos) << r.output;

  EXPECT_FALSE(std::filesystem::exists(out));
  for (const auto& entry : std::filesystem::directory_iterator(dir.path())) {
    EXPECT_EQ(entry.path().string().find(".tmp"), std::string::npos) << entry.path();
  }
}

TEST(BakeCli, AnOutputThatWouldDestroyAnInputOrCannotBeWrittenFailsBeforeTheBake) {
  testing::TempDir dir;
  const auto mesh = dir / "mesh.obj";
  std::filesystem::copy_file(kMesh, mesh);
  const std::string before = bytes_of(mesh);
  const std::string inputs = "bake --mesh " + quoted(mesh) + " --cage " + quoted(kCage) + " -o ";
  const auto refused = [&](const std::filesystem::path& output, const std::string& part) {
    const Result r = run(inputs + quoted(output));
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_NE(r.output.find(part), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("assign:"), std::string::npos) << "the bake ran before the check\n" << r.output;
  };
  refused(mesh, "is the input");
  refused(std::filesystem::path(kCage).replace_extension(".ele"), "is the input");  // the pair's other half
  refused(dir.path(), "is a directory");
  refused(dir / "missing" / "b.h5", "does not exist");
  EXPECT_EQ(bytes_of(mesh), before);
}

TEST(BakeCli, AFullDiskIsExitOneWithNothingLeftBehind) {
  testing::TempDir dir;
  // A file-size limit (ulimit -f) fails the write as a full disk would.
  const Result r = testing::run_command("ulimit -f 64; exec " + std::string(FISSURE_BAKE_EXE) + " -q bake --mesh " +
                                        quoted(kMesh) + " --cage " + quoted(kCage) + " -o " + quoted(dir / "b.h5"));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("b.h5: cannot write: the file exceeds the size limit"), std::string::npos) << r.output;
  EXPECT_TRUE(std::filesystem::is_empty(dir.path()));
}

// `status` (issue 18): a bundle records where its inputs were, relative to itself, their
// SHA-256, the options and the bake's version; status says whether re-baking would change
// it, and its exit code tells a build or CI job what to do.
class BakePipeline : public ::testing::Test {
 protected:
  void SetUp() override {
    std::filesystem::create_directories(dir / "assets");
    std::filesystem::create_directories(dir / "out");
    std::filesystem::copy_file(kMesh, dir / "assets" / "m.obj");
    for (const char* ext : {".node", ".ele"}) {
      std::filesystem::copy_file(std::filesystem::path(kSmallCage).replace_extension(ext), dir / "assets" / (std::string("c") + ext));
    }
    const Result bake = run("-q bake --mesh " + quoted(dir / "assets" / "m.obj") + " --cage " + quoted(dir / "assets" / "c.node") +
                            " -o " + quoted(bundle) + " --wall-res 16");
    ASSERT_EQ(bake.exit_code, 0) << bake.output;
  }
  const std::filesystem::path kSmallCage = testing::data_dir() / "cages" / "bunny-5k-cage-10.node";
  testing::TempDir dir;
  std::filesystem::path bundle = dir / "out" / "b.h5";
};

TEST_F(BakePipeline, AFreshBundleIsUpToDateWhereverTheTreeIsMoved) {
  Result r = run("status " + quoted(bundle));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("b.h5: up-to-date"), std::string::npos) << r.output;
  // The same flags as the bake: still up to date.
  r = run("status " + quoted(bundle) + " --wall-res 16 --json");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("{\"up_to_date\":true,\"bundles\":[{\"bundle\":"), std::string::npos) << r.output;
  // Inputs are found relative to the bundle, so a moved checkout still checks.
  const auto moved = dir / "moved";
  std::filesystem::create_directories(moved);
  std::filesystem::rename(dir / "assets", moved / "assets");
  std::filesystem::rename(dir / "out", moved / "out");
  r = run("status " + quoted(moved / "out" / "b.h5"));
  EXPECT_EQ(r.exit_code, 0) << r.output;
}

TEST_F(BakePipeline, AChangedInputOptionOrMissingBundleIsStaleWithExit3) {
  std::ofstream(dir / "assets" / "c.ele", std::ios::app) << "# edited\n";
  Result r = run("status " + quoted(bundle) + " " + quoted(dir / "out" / "never-baked.h5"));
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_NE(r.output.find("cage " + (dir / "assets" / "c.node").string() + " changed since the bake"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("never-baked.h5: stale\n  not baked yet"), std::string::npos) << r.output;
  r = run("status " + quoted(bundle) + " --cage " + quoted(kSmallCage) + " --wall-res 32 --skip collision");
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_EQ(r.output.find("changed since the bake"), std::string::npos) << "the original cage was asked for: " << r.output;
  EXPECT_NE(r.output.find("options differ: stages [\"embedding\",\"walls\",\"collision\"] -> [\"embedding\",\"walls\"], "
                          "wall_resolution 16 -> 32"),
            std::string::npos)
      << r.output;
}

// Issue 42: a bundle whose spheres an older model made (before "sphere_version" was
// recorded: model 1, a fifth of the cage edge with 3 spheres a tet) is stale.
TEST_F(BakePipeline, ABundleWithSpheresOfAnOlderModelIsStale) {
  formats::Bundle b = formats::read_bundle(bundle);
  const std::string key = ",\"sphere_version\":" + std::to_string(bake::kSphereVersion);
  const std::size_t at = b.metadata.bake_options.find(key);
  ASSERT_NE(at, std::string::npos) << b.metadata.bake_options;
  b.metadata.bake_options.erase(at, key.size());
  formats::write_bundle(bundle, b);
  const Result r = run("status " + quoted(bundle));
  EXPECT_EQ(r.exit_code, 3) << r.output;
  EXPECT_NE(r.output.find("b.h5: stale\n  collision spheres of model 1; this bake makes model " +
                          std::to_string(bake::kSphereVersion)),
            std::string::npos)
      << r.output;
}

TEST_F(BakePipeline, AMissingInputIsExit4AndOutranksStale) {
  std::filesystem::remove(dir / "assets" / "m.obj");
  const Result r = run("status --json " + quoted(bundle) + " " + quoted(dir / "out" / "never-baked.h5"));
  EXPECT_EQ(r.exit_code, 4) << r.output;
  EXPECT_NE(r.output.find("\"state\":\"missing-input\",\"reasons\":[\"mesh " + (dir / "assets" / "m.obj").string() + " not found"),
            std::string::npos)
      << r.output;
  // Issue 45: a bundle copied away from its inputs is told how to point at them.
  EXPECT_NE(r.output.find("if the bundle was copied away from its inputs, pass --mesh and --cage)\"]"), std::string::npos)
      << r.output;
  // A bundle from before schema 1.2 does not know where its inputs were.
  const Result old = run("status " + quoted(std::filesystem::path(FISSURE_TEST_FILES_DIR) / "two-tet-schema-1.1.h5"));
  EXPECT_EQ(old.exit_code, 4) << old.output;
  EXPECT_NE(old.output.find("baked by test; this is fissure-bake "), std::string::npos) << old.output;
  EXPECT_NE(old.output.find("does not record where its mesh (tri.obj) was read (baked before schema 1.2): pass --mesh"),
            std::string::npos)
      << old.output;
}

TEST_F(BakePipeline, InputsOrFlagsForSeveralBundlesAreAUsageError) {
  const Result r = run("status " + quoted(bundle) + " " + quoted(bundle) + " --weld");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("describe one bundle, but 2 were given"), std::string::npos) << r.output;
}

// verify over several bundles for CI: budgets fail with the measured value against the
// limit, an unreadable bundle is reported and the rest still checked, and --junit writes
// the same verdicts as JUnit XML (one suite per bundle, one case per check).
TEST_F(BakePipeline, VerifyChecksBudgetsOverManyBundlesAndWritesJunit) {
  const auto junit = dir / "report.xml";
  const auto broken = dir.write("broken.h5", "not a bundle");
  const Result r = run("-q verify " + quoted(bundle) + " " + quoted(broken) + " " + quoted(bundle) +
                       " --max-instances-per-triangle 1.1 --max-spheres 100000 --max-tiles 10 --junit " + quoted(junit));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("FAIL  budget:tiles                 "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(" tiles exceeds the budget of 10 tiles"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("PASS"), std::string::npos) << "-q prints failures only: " << r.output;
  EXPECT_NE(r.output.find("error: " + broken.string() + ": not an HDF5 file"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("3 bundles: at least one FAILED"), std::string::npos) << r.output;

  const std::string xml = bytes_of(junit);
  // 9 invariants (no walls check fails here) + 3 budgets per readable bundle, twice, and
  // one read error; the instances budget holds or not as measured, tiles fails twice.
  EXPECT_NE(xml.find("<testsuites name=\"fissure-bake verify\" tests=\""), std::string::npos) << xml;
  EXPECT_NE(xml.find("errors=\"1\">"), std::string::npos) << xml;
  EXPECT_NE(xml.find("<testcase classname=\"" + broken.string() + "\" name=\"read\">\n      <error message=\"" + broken.string()),
            std::string::npos)
      << xml;
  EXPECT_NE(xml.find("name=\"budget:tiles\">\n      <failure message=\""), std::string::npos) << xml;
  EXPECT_NE(xml.find("name=\"barycentric-sums\"><system-out>"), std::string::npos) << xml;

  // Without budgets and with good bundles: exit 0 and every case passes.
  const Result ok = run("-q verify " + quoted(bundle) + " --junit " + quoted(junit));
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_NE(bytes_of(junit).find("failures=\"0\" errors=\"0\">"), std::string::npos) << bytes_of(junit);
  // The report never replaces a bundle.
  EXPECT_EQ(run("verify " + quoted(bundle) + " --junit " + quoted(bundle)).exit_code, 1);
  EXPECT_EQ(run("verify " + quoted(bundle)).exit_code, 0);
}

// Issue 45: the verdict tells a sound bundle over a budget from a broken one, and -q's
// failure lines name their bundle (a CI log interleaves many).
TEST_F(BakePipeline, VerifySaysOverBudgetNotInvalidAndQuietLinesNameTheBundle) {
  const Result r = run("-q verify " + quoted(bundle) + " --max-tiles 10");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find(bundle.string() + ": FAIL  budget:tiles "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(bundle.string() + ": over budget (invariants hold)\n"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("INVALID"), std::string::npos) << r.output;
}

// Issue 45: `verify --status` adds a "status" case per bundle, so the JUnit report fails
// exactly when `status` does (a stale bundle, a missing input) and passes otherwise.
TEST_F(BakePipeline, VerifyStatusPutsStaleAndMissingInputsInTheJunitReport) {
  const auto junit = dir / "report.xml";
  Result r = run("-q verify --status " + quoted(bundle) + " --junit " + quoted(junit));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  std::string xml = bytes_of(junit);
  EXPECT_NE(xml.find("failures=\"0\" errors=\"0\">"), std::string::npos) << xml;
  EXPECT_NE(xml.find("name=\"status\"><system-out>inputs, options and bake version match"), std::string::npos) << xml;

  std::ofstream(dir / "assets" / "c.ele", std::ios::app) << "# edited\n";
  r = run("-q verify --status " + quoted(bundle) + " --junit " + quoted(junit));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find(bundle.string() + ": stale (re-bake it) (invariants hold)"), std::string::npos) << r.output;
  xml = bytes_of(junit);
  EXPECT_NE(xml.find("name=\"status\">\n      <failure message=\"stale; cage "), std::string::npos) << xml;
  EXPECT_NE(xml.find("failures=\"1\" errors=\"0\">"), std::string::npos) << xml;

  std::filesystem::remove(dir / "assets" / "m.obj");
  r = run("-q verify --status " + quoted(bundle) + " --junit " + quoted(junit));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(bytes_of(junit).find("<failure message=\"missing-input; mesh "), std::string::npos) << bytes_of(junit);
}

// A real bake interrupted at moments spread over its run (reading, embedding, writing):
// whatever the moment, it either finished (exit 0, the bundle alone) or ended by the
// signal with nothing left behind: no bundle, no temporary.
TEST(BakeCli, ASignalAtAnyMomentLeavesTheBundleWholeOrNothing) {
  int interrupted = 0;
  for (const char* signal : {"TERM", "INT"}) {
    for (int ms = 10; ms <= 250; ms += 40) {
      testing::TempDir dir;
      const Result r = testing::run_command(std::string(FISSURE_BAKE_EXE) + " -q bake --mesh " + quoted(kMesh) + " --cage " +
                                            quoted(kCage) + " -o " + quoted(dir / "b.h5") + " & pid=$!; sleep " +
                                            std::to_string(ms / 1000.0) + "; kill -" + signal + " $pid; wait $pid; echo status=$?");
      const std::string at = std::string("SIG") + signal + " after " + std::to_string(ms) + " ms: ";
      const int expected_killed = 128 + (std::string(signal) == "TERM" ? SIGTERM : SIGINT);
      if (r.output.find("status=0") != std::string::npos) {
        EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()), {}), 1) << at << r.output;
        EXPECT_TRUE(std::filesystem::exists(dir / "b.h5")) << at << r.output;
      } else {
        EXPECT_NE(r.output.find("status=" + std::to_string(expected_killed)), std::string::npos) << at << r.output;
        // A signal that lands after the bundle was renamed into place (between its result
        // line and the exit) leaves it whole: then it must be the only file, and valid.
        if (!std::filesystem::is_empty(dir.path())) {
          EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()), {}), 1) << at << r.output;
          EXPECT_EQ(run("-q verify " + quoted(dir / "b.h5")).exit_code, 0) << at << r.output;
        }
        ++interrupted;
      }
    }
  }
  EXPECT_GT(interrupted, 0) << "no bake was interrupted: the test checked nothing";
}

// Inputs that crashed, hung or exhausted memory before issue 17 (tests/data/hostile/README.md).
TEST(BakeCli, HostileInputsFoundByFuzzingAreCleanErrors) {
  testing::TempDir dir;
  const auto hostile = std::filesystem::path(FISSURE_TEST_FILES_DIR) / "hostile";
  const auto cage = testing::data_dir() / "cages" / "bunny-5k-cage-10.node";
  for (const auto& entry : std::filesystem::directory_iterator(hostile)) {
    const auto& file = entry.path();
    if (file.extension() != ".ply" && file.extension() != ".off") continue;
    const Result r = run("-q bake --mesh " + quoted(file) + " --cage " + quoted(cage) + " -o " + quoted(dir / "b.h5"));
    const bool valid = file.filename().string().find("valid") != std::string::npos;
    EXPECT_EQ(r.exit_code, valid ? 0 : 1) << file << "\n" << r.output;
    if (!valid) {
      EXPECT_NE(r.output.find("error: " + file.string()), std::string::npos) << r.output;
    }
  }
  const auto bundle = hostile / "bundle-1.1-dimension-bad-alloc.h5";
  for (const char* command : {"inspect ", "verify "}) {
    const Result r = run(command + quoted(bundle));
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_NE(r.output.find("claims shape [274877907401]"), std::string::npos) << r.output;
  }
  // Under the sanitizers HDF5 crashes on this one inside the probe's child, and the
  // error says so; without them it reads a wrong shape, which the shape check refuses.
  const auto legacy = hostile / "bundle-1.0-attribute-message-asan-segv.h5";
  for (const char* command : {"inspect ", "verify "}) {
    const Result r = run(command + quoted(legacy));
    EXPECT_EQ(r.exit_code, 1) << r.output;
    EXPECT_NE(r.output.find("error: " + legacy.string() + ": "), std::string::npos) << r.output;
  }
}

TEST(BakeCli, AVertexFarOutsideTheCageIsAnErrorNamingIt) {
  testing::TempDir dir;
  // A small closed tetrahedron in the middle of the bunny's cage, one corner moved to 1e15
  // (which used to fail the bake's own final check, exit 2).
  const auto mesh = dir.write("far.obj", "v -0.02 0.1 0\nv 0.02 0.1 0\nv 0 0.14 0\nv 0 0.1 1e15\n"
                                         "f 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n");
  const Result r = run("bake --mesh " + quoted(mesh) + " --cage " + quoted(kCage) + " -o " + quoted(dir / "b.h5"));
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("does not cover " + mesh.string() + ": 1 vertices lie outside"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("first: vertex 3 at (0, 0.1, 1e+15)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("hint: enlarge the cage"), std::string::npos) << r.output;
}

TEST(BakeCli, AnObjWithTwoVertexFacesStillBakesWithoutThem) {
  testing::TempDir dir;
  std::ifstream in(kMesh);
  const auto mesh = dir.write("lines.obj", std::string(std::istreambuf_iterator<char>(in), {}) + "f 1 2\nf 3\n");
  const Result r = run("-q bake --mesh " + quoted(mesh) + " --cage " + quoted(kCage) + " -o " + quoted(dir / "b.h5"));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("5000 triangles"), std::string::npos) << r.output;
}

/// The sample bunny's OBJ text with `edit` applied to each face line (index among faces).
std::string bunny_with_faces(const std::function<std::string(std::size_t, const std::string&)>& edit) {
  std::ifstream in(kMesh);
  std::string out, line;
  std::size_t face = 0;
  while (std::getline(in, line)) out += (line.rfind("f ", 0) == 0 ? edit(face++, line) : line) + "\n";
  return out;
}

/// "f a b c" → "f a c b".
std::string reversed_face(const std::string& line) {
  std::istringstream tokens(line.substr(2));
  std::string a, b, c;
  tokens >> a >> b >> c;
  return "f " + a + " " + c + " " + b;
}

// Issue 17: these used to fail the bake's own collision-mass check (exit 2).
TEST(BakeCli, FlippedAndInsideOutTrianglesAreRepairedWithAWarning) {
  testing::TempDir dir;
  const auto stray = dir.write("stray.obj", bunny_with_faces([](std::size_t f, const std::string& line) {
    return f == 10 || f == 2000 || f == 4000 ? reversed_face(line) : line;
  }));
  const auto inside_out =
      dir.write("inside-out.obj", bunny_with_faces([](std::size_t, const std::string& line) { return reversed_face(line); }));
  for (const auto& [mesh, warning] : {std::pair{stray, "flipped 3 triangles whose winding disagreed"},
                                      std::pair{inside_out, "turned 1 inside-out closed pieces (5000 triangles)"}}) {
    const auto bundle = dir / (mesh.stem().string() + ".h5");
    const Result r = run("bake --mesh " + quoted(mesh) + " --cage " + quoted(kCage) + " -o " + quoted(bundle));
    EXPECT_EQ(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find("warning: " + mesh.string() + ": " + warning), std::string::npos) << r.output;
    const Result verify = run("verify " + quoted(bundle));
    EXPECT_EQ(verify.exit_code, 0) << verify.output;
    EXPECT_NE(verify.output.find("relative error"), std::string::npos) << verify.output;  // the total was compared
  }
}

TEST(BakeCli, ASelfIntersectingSurfaceBakesInAFineCageWithAWarning) {
  // The bunny and a copy of it 0.5 mm along x: two closed surfaces crossing everywhere,
  // in the 987-tet cage that hugs the bunny.
  testing::TempDir dir;
  std::ifstream in(kMesh);
  std::string vertices, faces, copy_vertices, copy_faces, line;
  std::size_t count = 0;
  while (std::getline(in, line)) {
    std::istringstream tokens(line.substr(std::min<std::size_t>(2, line.size())));
    if (line.rfind("v ", 0) == 0) {
      double x, y, z;
      tokens >> x >> y >> z;
      vertices += line + "\n";
      copy_vertices += "v " + std::to_string(x + 0.0005) + " " + std::to_string(y) + " " + std::to_string(z) + "\n";
      ++count;
    } else if (line.rfind("f ", 0) == 0) {
      faces += line + "\n";
      copy_faces += "f";
      for (std::string corner; tokens >> corner;) copy_faces += " " + std::to_string(std::stoul(corner) + count);
      copy_faces += "\n";
    }
  }
  const std::string text = vertices + copy_vertices + faces + copy_faces;
  const auto mesh = dir.write("crossing.obj", text);
  const auto cage = testing::data_dir() / "cages" / "bunny-5k-cage-987.node";
  const Result r = run("bake --mesh " + quoted(mesh) + " --cage " + quoted(cage) + " -o " + quoted(dir / "b.h5"));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("pairs of triangles cross each other; baked as they are"), std::string::npos) << r.output;
  const Result verify = run("verify " + quoted(dir / "b.h5"));
  EXPECT_EQ(verify.exit_code, 0) << verify.output;
  EXPECT_NE(verify.output.find("the surface crosses itself"), std::string::npos) << verify.output;
}

TEST(BakeCli, StageOptionsChooseTheGroupsWritten) {
  testing::TempDir dir;
  const std::string inputs = " --mesh " + quoted(kMesh) + " --cage " + quoted(kCage);
  ASSERT_EQ(run("-q bake" + inputs + " --skip walls -o " + quoted(dir / "no-walls.h5")).exit_code, 0);
  Result r = run("inspect --json " + quoted(dir / "no-walls.h5"));
  EXPECT_NE(r.output.find("\"stages\":[\"embedding\",\"collision\"]"), std::string::npos) << r.output;
  EXPECT_EQ(run("verify " + quoted(dir / "no-walls.h5")).exit_code, 0);

  ASSERT_EQ(run("-q bake" + inputs + " --only walls --wall-res 16 -o " + quoted(dir / "walls.h5")).exit_code, 0);
  r = run("inspect --json " + quoted(dir / "walls.h5"));
  EXPECT_NE(r.output.find("\"stages\":[\"embedding\",\"walls\"]"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("\"wall_resolution\":16"), std::string::npos) << r.output;
  r = run("verify " + quoted(dir / "walls.h5"));
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("PASS  walls"), std::string::npos) << r.output;
}

TEST(BakeCli, BadStageOptionsAreClearErrors) {
  testing::TempDir dir;
  const std::string inputs = " --mesh " + quoted(kMesh) + " --cage " + quoted(kCage) + " -o " + quoted(dir / "x.h5");
  for (const auto& [options, needle] : std::vector<std::pair<std::string, std::string>>{
           {"--wall-res 0", "--wall-res 0 must be positive"},
           {"--wall-res -8", "--wall-res"},
           {"--sphere-radius 0", "--sphere-radius"},
           {"--sphere-radius -0.01", "--sphere-radius"},
           {"--sphere-radius 1e308", "is larger than the cage"},
           {"--surface-spacing 0.1", "--surface-spacing"},
           {"--surface-spacing 100", "--surface-spacing"},
           {"--wall-res 4096 --wall-memory-budget 1", "over the budget"},
           {"--only walls --skip collision", "cannot be combined"},
           {"--only fracture", "fracture"}}) {
    const Result r = run("bake" + inputs + " " + options);
    EXPECT_NE(r.exit_code, 0) << options;
    EXPECT_NE(r.output.find(needle), std::string::npos) << options << "\n" << r.output;
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "x.h5"));
}

TEST(BakeCli, VerifyFailsOnACorruptBundle) {
  testing::TempDir dir;
  const Result r = run("verify " + quoted(dir.write("junk.h5", "not hdf5")));
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.output.find("not an HDF5 file"), std::string::npos) << r.output;
}

TEST(BakeCli, UsageErrorsAndHelp) {
  EXPECT_NE(run("").exit_code, 0);
  const Result help = run("--help");
  EXPECT_EQ(help.exit_code, 0);
  for (const char* command : {"bake", "cage", "inspect", "verify", "replication"}) {
    EXPECT_NE(help.output.find(command), std::string::npos) << help.output;
  }
  const Result missing = run("bake --mesh x.obj");
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_NE(missing.output.find("--output"), std::string::npos) << missing.output;
  // Neither --cage nor --tets (issue 43: the cage may be made from the mesh).
  testing::TempDir dir;
  const Result no_cage = run("bake --mesh x.obj -o " + quoted(dir / "b.h5"));
  EXPECT_EQ(no_cage.exit_code, 1);
  EXPECT_NE(no_cage.output.find("give --cage FILE, or --tets N"), std::string::npos) << no_cage.output;
}

TEST(BakeCli, ReplicationTableCountsEveryTriangle) {
  const Result r = run("replication " + quoted(kMesh) + " --cages " + quoted(kCage) + " " +
                       quoted(testing::data_dir() / "cages" / "bunny-5k-cage-10.node") + " --json");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("\"cage\":\"bunny-5k-cage-100.node\",\"tets\":100"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("\"cage\":\"bunny-5k-cage-10.node\",\"tets\":10"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace fissure
