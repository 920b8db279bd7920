// The child probe: a crash in the child is reported, not suffered; an exception or a
// return is an orderly end; nothing the child does reaches the parent.
#include "common/child_probe.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdlib>
#include <stdexcept>
#include <vector>

#include "common/error.h"

namespace fissure {
namespace {

TEST(ChildProbe, AReturnOrAnExceptionIsAFinishedProbe) {
  EXPECT_TRUE(run_in_child([] {}).finished);
  EXPECT_TRUE(run_in_child([] { throw std::runtime_error("bad input"); }).finished);
}

TEST(ChildProbe, ACrashInTheChildIsReportedWithItsSignal) {
  // SIGABRT (a failed assertion inside a library): ASan leaves it alone, whereas it
  // turns a SIGSEGV into its own report and exit(1), the next test's case.
  const ChildProbeOutcome outcome = run_in_child([] { std::abort(); });
  EXPECT_FALSE(outcome.finished);
  EXPECT_EQ(outcome.how.rfind("killed by signal 6", 0), 0u) << outcome.how;
}

TEST(ChildProbe, AnExitStatusOtherThanZeroIsNotFinished) {
  // What a sanitizer does when it finds an error in the child: report, then exit(1).
  const ChildProbeOutcome outcome = run_in_child([] { std::exit(1); });
  EXPECT_FALSE(outcome.finished);
  EXPECT_EQ(outcome.how, "exited with status 1");
}

TEST(ChildProbe, OnlyTheChildKnowsItIsInsideAProbe) {
  EXPECT_FALSE(inside_child_probe());
  int seen_in_parent = 0;
  const ChildProbeOutcome outcome = run_in_child([&] {
    seen_in_parent = 1;  // the child's copy: the parent's stays 0
    if (!inside_child_probe()) std::abort();
  });
  EXPECT_TRUE(outcome.finished) << outcome.how;
  EXPECT_EQ(seen_in_parent, 0);
  EXPECT_FALSE(inside_child_probe());
}

// Issue 46: assimp's Collada, SMD and NFF readers hang on some damaged files; the probe
// used to wait for its child for ever.
TEST(ChildProbe, AChildThatNeverEndsIsStoppedAtTheWallClockLimit) {
  ChildProbeLimits limits;
  limits.wall_seconds = 0.3;
  const auto start = std::chrono::steady_clock::now();
  const ChildProbeOutcome outcome = run_in_child([] {
    for (;;) {
    }
  }, limits);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_FALSE(outcome.finished);
  EXPECT_TRUE(outcome.timed_out);
  EXPECT_LT(seconds, 3.0);
  EXPECT_EQ(outcome.how, "did not finish within 0.3 s (stopped)");
}

// Not under ASan: its allocator aborts on a failed mmap rather than throwing bad_alloc,
// and its shadow memory needs an address space no such limit allows.
#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define FISSURE_UNDER_ASAN 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__)
#define FISSURE_UNDER_ASAN 1
#endif
#ifndef FISSURE_UNDER_ASAN
TEST(ChildProbe, AChildThatKeepsAllocatingIsStoppedByTheMemoryLimit) {
  ChildProbeLimits limits;
  limits.memory_bytes = std::uint64_t{256} << 20;
  limits.wall_seconds = 20;
  const ChildProbeOutcome outcome = run_in_child([] {
    std::vector<std::vector<char>> blocks;
    for (int i = 0; i < 64; ++i) blocks.emplace_back(std::size_t{64} << 20, 'x');  // 4 GiB in all
  }, limits);
  EXPECT_FALSE(outcome.finished);
  EXPECT_TRUE(outcome.out_of_memory) << outcome.how;
  EXPECT_FALSE(outcome.timed_out);
}
#endif

TEST(ChildProbe, AnErrorInTheChildComesBackWithItsHint) {
  const ChildProbeOutcome outcome = run_in_child([] { throw Error("mesh.dae: bad index", "export it again"); });
  EXPECT_TRUE(outcome.finished);
  EXPECT_EQ(outcome.error, "mesh.dae: bad index");
  EXPECT_EQ(outcome.error_hint, "export it again");
  EXPECT_TRUE(run_in_child([] {}).error.empty());
}

}  // namespace
}  // namespace fissure
