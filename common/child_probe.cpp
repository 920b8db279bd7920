#include "common/child_probe.h"

#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "common/error.h"

namespace fissure {
namespace {

constexpr int kProbeFinished = 0;
bool g_inside_child_probe = false;

std::string describe(int status) {
  if (WIFSIGNALED(status)) {
    const int signal = WTERMSIG(status);
    return "killed by signal " + std::to_string(signal) + " (" + strsignal(signal) + ")";
  }
  return "exited with status " + std::to_string(WEXITSTATUS(status));
}

}  // namespace

ChildProbeOutcome run_in_child(const std::function<void()>& probe) {
  const pid_t child = fork();
  if (child < 0) throw Error(std::string("cannot fork a process to read the file safely: ") + std::strerror(errno));
  if (child == 0) {
    g_inside_child_probe = true;
    try {
      probe();
    } catch (...) {
      // An exception is an orderly end: the parent repeats the call and gets it.
    }
    _exit(kProbeFinished);
  }
  int status = 0;
  while (waitpid(child, &status, 0) < 0) {
    if (errno != EINTR) throw Error(std::string("cannot wait for the reading process: ") + std::strerror(errno));
  }
  const bool finished = WIFEXITED(status) && WEXITSTATUS(status) == kProbeFinished;
  return {finished, describe(status)};
}

bool inside_child_probe() { return g_inside_child_probe; }

}  // namespace fissure
