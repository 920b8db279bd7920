// The child probe: a crash in the child is reported, not suffered; an exception or a
// return is an orderly end; nothing the child does reaches the parent.
#include "common/child_probe.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <stdexcept>

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

}  // namespace
}  // namespace fissure
