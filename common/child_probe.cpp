#include "common/child_probe.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/syscall.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <new>
#include <thread>

#include "common/error.h"

namespace fissure {
namespace {

constexpr int kProbeFinished = 0;
/// The child's exit status when an allocation failed under the memory limit: not a
/// status a sanitizer uses (1) or a shell reports for signals (128+).
constexpr int kProbeOutOfMemory = 87;
bool g_inside_child_probe = false;

std::string describe(int status) {
  if (WIFSIGNALED(status)) {
    const int signal = WTERMSIG(status);
    return "killed by signal " + std::to_string(signal) + " (" + strsignal(signal) + ")";
  }
  return "exited with status " + std::to_string(WEXITSTATUS(status));
}

std::string seconds_text(double seconds) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g s", seconds);
  return text;
}

/// The address space the process holds now (VmSize), from /proc; 0 if unknown.
std::uint64_t address_space_in_use() {
  std::FILE* statm = std::fopen("/proc/self/statm", "r");
  if (statm == nullptr) return 0;
  unsigned long long pages = 0;
  const int read = std::fscanf(statm, "%llu", &pages);
  std::fclose(statm);
  return read == 1 ? pages * static_cast<std::uint64_t>(::sysconf(_SC_PAGESIZE)) : 0;
}

/// In the child, before the probe: its limits, and no core dumps of damaged input.
void limit_child(const ChildProbeLimits& limits) {
  const rlimit no_core{0, 0};
  ::setrlimit(RLIMIT_CORE, &no_core);
  if (limits.cpu_seconds > 0) {
    const auto soft = static_cast<rlim_t>(std::ceil(limits.cpu_seconds));
    const rlimit cpu{soft, soft + 1};
    ::setrlimit(RLIMIT_CPU, &cpu);
  }
  if (limits.memory_bytes > 0) {
    // On top of what the child inherits (the parent's libraries, heap and, under a
    // sanitizer, its shadow reservations), so the budget is what the probe adds.
    const rlim_t total = static_cast<rlim_t>(address_space_in_use() + limits.memory_bytes);
    rlimit current{};
    ::getrlimit(RLIMIT_AS, &current);
    if (current.rlim_cur == RLIM_INFINITY || current.rlim_cur > total) {
      const rlimit as{total, current.rlim_max};
      ::setrlimit(RLIMIT_AS, &as);
    }
  }
}

/// Sends an error to the parent: message, a NUL, hint. Short enough for one page of pipe
/// buffer (4096 bytes, the least Linux gives a pipe), so the write never waits for the
/// parent, which reads after the child ends. Never throws: it runs in the forked child,
/// where an escaping exception would run the parent's code on.
void send_error(int fd, const Error& e) noexcept {
  constexpr std::size_t kMost = 2000;
  std::string text = std::string(e.what()).substr(0, kMost);
  text += '\0';
  text += e.hint().substr(0, kMost);
  const char* data = text.data();
  std::size_t left = text.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, data, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;
    data += n;
    left -= static_cast<std::size_t>(n);
  }
}

[[noreturn]] void run_child(const std::function<void()>& probe, const ChildProbeLimits& limits, int error_fd) {
  g_inside_child_probe = true;
  limit_child(limits);
  try {
    probe();
  } catch (const std::bad_alloc&) {
    _exit(kProbeOutOfMemory);
  } catch (const Error& e) {
    send_error(error_fd, e);  // an orderly end: the parent reports it
  } catch (...) {
    // Any other exception is an orderly end too: the parent repeats the call and gets it.
  }
  _exit(kProbeFinished);
}

void read_error(int fd, ChildProbeOutcome& outcome) {
  std::string text;
  char buffer[4096];
  for (;;) {
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    text.append(buffer, static_cast<std::size_t>(n));
  }
  const std::size_t split = text.find('\0');
  if (split == std::string::npos) return;
  outcome.error = text.substr(0, split);
  outcome.error_hint = text.substr(split + 1);
}

/// Waits up to `seconds` for the child to end, without polling where the kernel can
/// say when (a pidfd, Linux 5.3+); otherwise sleeps in short, growing steps.
void wait_until_ended_or(pid_t child, double seconds) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  const int fd = static_cast<int>(::syscall(SYS_pidfd_open, child, 0));
  auto pause = std::chrono::microseconds(200);
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) break;
    if (fd >= 0) {
      pollfd ended{fd, POLLIN, 0};
      const int ready = ::poll(&ended, 1, static_cast<int>(std::min<long long>(left.count() + 1, 1 << 30)));
      if (ready != 0 && !(ready < 0 && errno == EINTR)) break;
      continue;
    }
    siginfo_t info{};
    if (::waitid(P_PID, static_cast<id_t>(child), &info, WEXITED | WNOHANG | WNOWAIT) == 0 && info.si_pid == child) break;
    std::this_thread::sleep_for(std::min<std::chrono::microseconds>(pause, left));
    pause = std::min(pause * 2, std::chrono::microseconds(20000));
  }
  if (fd >= 0) ::close(fd);
}

/// Waits for the child, killing it once `wall_seconds` have passed (0: waits as long as
/// it takes). Returns the status, and whether it had to kill.
int wait_for(pid_t child, double wall_seconds, bool& killed) {
  killed = false;
  if (wall_seconds > 0) {
    wait_until_ended_or(child, wall_seconds);
    int status = 0;
    const pid_t done = ::waitpid(child, &status, WNOHANG);
    if (done == child) return status;
    ::kill(child, SIGKILL);
    killed = true;
  }
  int status = 0;
  while (::waitpid(child, &status, 0) < 0) {
    if (errno != EINTR) throw Error(std::string("cannot wait for the reading process: ") + std::strerror(errno));
  }
  return status;
}

}  // namespace

ChildProbeOutcome run_in_child(const std::function<void()>& probe, const ChildProbeLimits& limits) {
  int error_pipe[2];
  if (::pipe2(error_pipe, O_CLOEXEC) != 0) {
    throw Error(std::string("cannot make a pipe to read the file safely: ") + std::strerror(errno));
  }
  const pid_t child = fork();
  if (child < 0) {
    ::close(error_pipe[0]);
    ::close(error_pipe[1]);
    throw Error(std::string("cannot fork a process to read the file safely: ") + std::strerror(errno));
  }
  if (child == 0) {
    ::close(error_pipe[0]);
    run_child(probe, limits, error_pipe[1]);
  }
  ::close(error_pipe[1]);
  bool killed = false;
  int status = 0;
  try {
    status = wait_for(child, limits.wall_seconds, killed);
  } catch (...) {
    ::close(error_pipe[0]);
    throw;
  }
  ChildProbeOutcome outcome;
  read_error(error_pipe[0], outcome);
  ::close(error_pipe[0]);
  outcome.finished = !killed && WIFEXITED(status) && WEXITSTATUS(status) == kProbeFinished;
  if (killed) {
    outcome.timed_out = true;
    outcome.how = "did not finish within " + seconds_text(limits.wall_seconds) + " (stopped)";
  } else if (WIFSIGNALED(status) && (WTERMSIG(status) == SIGXCPU || WTERMSIG(status) == SIGKILL) &&
             limits.cpu_seconds > 0) {
    outcome.timed_out = true;
    outcome.how = "used more than " + seconds_text(limits.cpu_seconds) + " of processor time (stopped)";
  } else if (WIFEXITED(status) && WEXITSTATUS(status) == kProbeOutOfMemory) {
    outcome.out_of_memory = true;
    outcome.how = "ran out of its memory budget (" + std::to_string(limits.memory_bytes >> 20) + " MiB)";
  } else {
    outcome.how = describe(status);
  }
  return outcome;
}

bool inside_child_probe() { return g_inside_child_probe; }

}  // namespace fissure
