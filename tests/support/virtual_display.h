#pragma once
/// One Xvfb server (Debian `xvfb`) for a test process's window tests.
///
/// Started with `-displayfd`, so the server itself picks a free display number and says
/// which. `xvfb-run -a` guesses a number per command instead, and its clean-up can fail
/// (exit 5, "problem while cleaning up temporary directory") when the command exits at
/// once, which made a passing test fail in CI. One server per process is also faster.

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <string>

namespace fissure::testing {

class VirtualDisplay {
 public:
  /// The process's server, started on first use; `available()` is false if it could not start.
  static const VirtualDisplay& shared() {
    static const VirtualDisplay display;
    return display;
  }
  [[nodiscard]] bool available() const { return !m_display.empty(); }
  /// Prefix for a shell command line that runs it on this display.
  [[nodiscard]] std::string env_prefix() const { return "DISPLAY=:" + m_display + " "; }

  VirtualDisplay(const VirtualDisplay&) = delete;
  VirtualDisplay& operator=(const VirtualDisplay&) = delete;
  ~VirtualDisplay() {
    if (m_pid <= 0) return;
    ::kill(m_pid, SIGTERM);
    ::waitpid(m_pid, nullptr, 0);
  }

 private:
  VirtualDisplay() {
    int fds[2];
    if (::pipe(fds) != 0) return;
    m_pid = ::fork();
    if (m_pid == 0) exec_server(fds[1]);
    ::close(fds[1]);
    if (m_pid > 0) m_display = read_display_number(fds[0]);
    ::close(fds[0]);
  }

  [[noreturn]] static void exec_server(int display_fd) {
    ::prctl(PR_SET_PDEATHSIG, SIGTERM);  // a test process killed by a timeout takes its server along
    const int null = ::open("/dev/null", O_WRONLY);
    ::dup2(null, STDOUT_FILENO);
    ::dup2(null, STDERR_FILENO);
    const std::string fd = std::to_string(display_fd);
    ::execlp("Xvfb", "Xvfb", "-displayfd", fd.c_str(), "-screen", "0", "640x480x24", "-nolisten", "tcp",
             static_cast<char*>(nullptr));
    ::_exit(127);
  }

  /// The number the server writes once it accepts connections; empty after 20 s or on exit.
  static std::string read_display_number(int fd) {
    std::string number;
    pollfd wait_for{fd, POLLIN, 0};
    char c = 0;
    while (::poll(&wait_for, 1, 20000) == 1 && ::read(fd, &c, 1) == 1 && c != '\n') number += c;
    return c == '\n' ? number : std::string();
  }

  pid_t m_pid = -1;
  std::string m_display;
};

}  // namespace fissure::testing
