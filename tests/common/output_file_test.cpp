// Output files: atomic writes, checks before the work, and nothing left behind on a
// full disk or a signal. The failing cases run in a forked child, whose limits and
// signal handlers must not touch the test process.
#include "common/output_file.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <functional>

#include "common/error.h"
#include "common/input_file.h"
#include "tests/support/temp_dir.h"

namespace fissure {
namespace {

/// Runs `body` in a child process; returns its wait status.
int in_child(const std::function<int()>& body) {
  const pid_t pid = ::fork();
  if (pid == 0) ::_exit(body());
  int status = 0;
  ::waitpid(pid, &status, 0);
  return status;
}

std::size_t files_in(const std::filesystem::path& folder) {
  std::size_t count = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(folder)) ++count;
  return count;
}

TEST(OutputFile, WritesTheBytesAndLeavesNoTemporary) {
  testing::TempDir dir;
  write_file_atomically(dir / "a.txt", "hello");
  write_file_atomically(dir / "a.txt", "replaced");
  std::ifstream in(dir / "a.txt");
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(in), {}), "replaced");
  EXPECT_EQ(files_in(dir.path()), 1U);
}

TEST(OutputFile, AFullDiskIsACleanErrorThatLeavesNothing) {
  testing::TempDir dir;
  // A file-size limit fails writes with EFBIG, as ENOSPC would on a full disk.
  const int status = in_child([&] {
    install_output_signal_handlers();
    const rlimit limit{4096, 4096};
    ::setrlimit(RLIMIT_FSIZE, &limit);
    try {
      write_file_atomically(dir / "big.bin", std::string(100000, 'x'));
    } catch (const Error& e) {
      const std::string message = e.what();
      return message.find("big.bin") != std::string::npos && message.find("size limit") != std::string::npos ? 0 : 3;
    }
    return 4;
  });
  ASSERT_TRUE(WIFEXITED(status)) << "the child died of signal " << WTERMSIG(status);
  EXPECT_EQ(WEXITSTATUS(status), 0);
  EXPECT_EQ(files_in(dir.path()), 0U);
}

TEST(OutputFile, SigtermRemovesTheTemporaryBeingWrittenAndStillEndsTheProcess) {
  testing::TempDir dir;
  const int status = in_child([&] {
    install_output_signal_handlers();
    const TemporaryOutput temporary(dir / "out.h5");
    std::ofstream(temporary.path()) << "half";
    ::raise(SIGTERM);
    return 0;
  });
  ASSERT_TRUE(WIFSIGNALED(status));
  EXPECT_EQ(WTERMSIG(status), SIGTERM);
  EXPECT_EQ(files_in(dir.path()), 0U);
}

TEST(OutputFile, ChecksRefuseDirectoriesMissingFoldersAndInputs) {
  testing::TempDir dir;
  const auto input = dir.write("mesh.obj", "v 0 0 0\n");
  const auto expect_refused = [&](const std::filesystem::path& path, const std::string& part) {
    try {
      check_output_path(path, {input}, "-o");
      ADD_FAILURE() << path << " was accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("-o "), std::string::npos) << e.what();
    }
  };
  expect_refused(dir.path(), "is a directory");
  expect_refused(dir / "no" / "out.h5", "does not exist");
  expect_refused(input, "is the input");
  expect_refused(dir / "." / "mesh.obj", "is the input");  // the same file by another name
  EXPECT_NO_THROW(check_output_path(dir / "out.h5", {input}, "-o"));
  // A directory's hint suggests a file inside it of the kind the option writes.
  const auto hint_for_directory = [&](const std::function<void()>& check) {
    try {
      check();
    } catch (const Error& e) {
      return e.hint();
    }
    return std::string("accepted");
  };
  EXPECT_EQ(hint_for_directory([&] { check_output_path(dir.path(), {}, "-o"); }),
            "give a file name inside it, e.g. " + (dir.path() / "out.h5").string());
  EXPECT_EQ(hint_for_directory([&] { check_output_path(dir.path(), {}, "--report", "report.json"); }),
            "give a file name inside it, e.g. " + (dir.path() / "report.json").string());
}

TEST(OutputFile, ChecksRemoveOnlyTemporariesWhoseRunIsGone) {
  testing::TempDir dir;
  const auto stale = dir.write("out.h5.tmp-999999999", "left by a killed run");
  const auto live = dir.write("out.h5.tmp-" + std::to_string(::getppid()), "another run, still writing");
  const auto other = dir.write("other.h5.tmp-999999999", "not ours");
  check_output_path(dir / "out.h5", {}, "-o");
  EXPECT_FALSE(std::filesystem::exists(stale));
  EXPECT_TRUE(std::filesystem::exists(live));
  EXPECT_TRUE(std::filesystem::exists(other));
}

// Issue 46: the rename that makes a write atomic replaced whatever the output named, so
// -o FIFO left a regular file in its place (and as root, -o /dev/null would replace the
// system's /dev/null). Checking /dev/null only stats it: nothing is written there.
TEST(OutputFile, FifosDevicesAndSocketsAreRefusedAndNeverReplaced) {
  testing::TempDir dir;
  const auto fifo = dir / "out.h5";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const auto message_of = [](const std::function<void()>& f) -> std::string {
    try {
      f();
    } catch (const Error& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_EQ(message_of([&] { check_output_path(fifo, {}, "-o"); }),
            "-o " + fifo.string() + ": is a FIFO (named pipe), not a regular file; writing would replace it with a "
            "regular file");
  EXPECT_EQ(message_of([&] { check_output_path("/dev/null", {}, "--report"); }),
            "--report /dev/null: is a character device, not a regular file; writing would replace it with a regular "
            "file");
  // The last line of defence, for a caller that did not check first.
  EXPECT_NE(message_of([&] { write_file_atomically(fifo, "bytes"); }).find("is a FIFO"), std::string::npos);
  EXPECT_TRUE(std::filesystem::is_fifo(fifo));
  EXPECT_EQ(files_in(dir.path()), 1u);  // no temporary left beside it
}

TEST(InputFile, StreamsAndDevicesAreRefusedBeforeOpeningAndSizesAreCapped) {
  testing::TempDir dir;
  const auto fifo = dir / "scene.toml";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  // Opening a FIFO without a writer blocks: the refusal must come before.
  EXPECT_THROW(read_input_file(fifo), Error);
  EXPECT_THROW(read_input_file("/dev/zero"), Error);
  try {
    read_input_file("/dev/zero");
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "/dev/zero: is a character device, not a regular file; Fissure reads inputs only "
                                     "from regular files");
  }
  std::filesystem::create_symlink("loop", dir / "loop");
  try {
    read_input_file(dir / "loop");
    ADD_FAILURE() << "a link to itself was read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot be read: Too many levels of symbolic links"), std::string::npos);
  }
  const auto text = dir.write("small.txt", std::string(100, 'x'));
  EXPECT_EQ(read_input_file(text).size(), 100u);
  EXPECT_THROW(read_input_file(text, 99), Error);
}

}  // namespace
}  // namespace fissure
