#include "common/output_file.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <climits>
#include <cstring>
#include <system_error>

#include "common/error.h"
#include "common/input_file.h"
#include "common/log.h"

namespace fissure {
namespace {

// The signal handler may only touch these: fixed arrays, no allocation.
constexpr int kSlots = 16;
enum SlotState : int { kFree = 0, kFilling = 1, kLive = 2 };
std::array<std::atomic<int>, kSlots> g_slot_state{};
std::array<std::array<char, PATH_MAX>, kSlots> g_slot_path{};

int register_temporary(const std::filesystem::path& path) {
  const std::string& text = path.native();
  if (text.size() >= PATH_MAX) return -1;
  for (int s = 0; s < kSlots; ++s) {
    int expected = kFree;
    if (!g_slot_state[s].compare_exchange_strong(expected, kFilling)) continue;
    std::memcpy(g_slot_path[s].data(), text.c_str(), text.size() + 1);
    g_slot_state[s].store(kLive);
    return s;
  }
  return -1;  // more than kSlots outputs at once: still removed on failure, not on a signal
}

void unregister_temporary(int slot) {
  if (slot >= 0) g_slot_state[slot].store(kFree);
}

extern "C" void remove_temporaries_and_reraise(int signal_number) {
  for (int s = 0; s < kSlots; ++s) {
    if (g_slot_state[s].load() == kLive) ::unlink(g_slot_path[s].data());
  }
  ::signal(signal_number, SIG_DFL);
  ::raise(signal_number);
}

std::string describe_errno(int error) {
  if (error == ENOSPC || error == EDQUOT) return "the disk is full";
  if (error == EFBIG) return "the file exceeds the size limit (ulimit -f)";
  return std::strerror(error);
}

/// "<name>.tmp-<pid>" beside `path` whose process no longer runs.
bool is_stale_temporary_of(const std::filesystem::path& candidate, const std::string& prefix) {
  const std::string name = candidate.filename().string();
  if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) return false;
  const std::string digits = name.substr(prefix.size());
  if (digits.size() > 9 || digits.find_first_not_of("0123456789") != std::string::npos) return false;
  const auto pid = static_cast<pid_t>(std::stol(digits));
  return pid != ::getpid() && ::kill(pid, 0) != 0 && errno == ESRCH;
}

void remove_stale_temporaries(const std::filesystem::path& path) {
  const std::filesystem::path folder = path.has_parent_path() ? path.parent_path() : ".";
  const std::string prefix = path.filename().string() + ".tmp-";
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(folder, ec)) {
    if (!is_stale_temporary_of(entry.path(), prefix)) continue;
    std::error_code removed;
    if (std::filesystem::remove(entry.path(), removed)) {
      log_warning("removed " + entry.path().string() + ", a temporary left by a run that was killed while writing");
    }
  }
}

/// Writing renames a finished temporary over the output, which would replace a FIFO,
/// a device or a socket with a regular file: as root, `-o /dev/null` would replace the
/// system's /dev/null (issue 46). Such outputs are refused instead.
void require_not_special(const std::filesystem::path& path, std::string_view option) {
  const std::string kind = special_file_kind(path);
  if (kind.empty()) return;
  throw Error(std::string(option) + " " + path.string() + ": is " + kind +
                  ", not a regular file; writing would replace it with a regular file",
              "give the name of a regular file (or a new one); Fissure never writes to streams or devices");
}

bool same_file(const std::filesystem::path& a, const std::filesystem::path& b) {
  std::error_code ec;
  return std::filesystem::equivalent(a, b, ec);
}

void write_all(int fd, std::string_view bytes, const std::filesystem::path& path) {
  std::size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + written, bytes.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int error = n < 0 ? errno : ENOSPC;
      throw Error(path.string() + ": cannot write: " + describe_errno(error) + " (" + std::to_string(written) + " of " +
                      std::to_string(bytes.size()) + " bytes written; nothing was kept)",
                  "free space on that disk or write elsewhere");
    }
    written += static_cast<std::size_t>(n);
  }
}

}  // namespace

void install_output_signal_handlers() {
  struct sigaction action {};
  action.sa_handler = remove_temporaries_and_reraise;
  sigemptyset(&action.sa_mask);
  for (const int s : {SIGINT, SIGTERM, SIGHUP}) ::sigaction(s, &action, nullptr);
  ::signal(SIGXFSZ, SIG_IGN);
}

void check_output_path(const std::filesystem::path& path, const std::vector<std::filesystem::path>& inputs,
                       std::string_view option, std::string_view example) {
  const std::string name = path.string();
  const std::string where = std::string(option) + " " + name;
  std::error_code ec;
  if (path.empty()) throw Error(std::string(option) + ": the output path is empty");
  if (std::filesystem::is_directory(path, ec)) {
    throw Error(where + ": is a directory", "give a file name inside it, e.g. " + (path / example).string());
  }
  require_not_special(path, option);
  for (const auto& input : inputs) {
    if (same_file(path, input)) {
      throw Error(where + ": is the input " + input.string() + "; writing it would destroy the input",
                  "choose another output name");
    }
  }
  const std::filesystem::path folder = path.has_parent_path() ? path.parent_path() : ".";
  if (!std::filesystem::is_directory(folder, ec)) {
    throw Error(where + ": the folder " + folder.string() + " does not exist", "create it first, or write elsewhere");
  }
  if (::access(folder.c_str(), W_OK | X_OK) != 0) {
    throw Error(where + ": the folder " + folder.string() + " is not writable", "write elsewhere, or fix its permissions");
  }
  remove_stale_temporaries(path);
}

TemporaryOutput::TemporaryOutput(std::filesystem::path final_path)
    : m_final(std::move(final_path)),
      m_temporary(m_final.string() + ".tmp-" + std::to_string(static_cast<long>(::getpid()))),
      m_slot(register_temporary(m_temporary)) {}

TemporaryOutput::~TemporaryOutput() {
  if (!m_committed) ::unlink(m_temporary.c_str());
  unregister_temporary(m_slot);
}

void TemporaryOutput::commit() {
  // Checked before the work too (check_output_path); this is the last moment, in case
  // one appeared meanwhile or the caller did not check.
  require_not_special(m_final, "output");
  std::error_code ec;
  std::filesystem::rename(m_temporary, m_final, ec);
  if (ec) throw Error(m_final.string() + ": cannot move the finished file into place: " + ec.message());
  m_committed = true;
}

void write_file_atomically(const std::filesystem::path& path, std::string_view bytes, bool sync) {
  TemporaryOutput temporary(path);
  const int fd = ::open(temporary.path().c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd < 0) {
    throw Error(path.string() + ": cannot create the file: " + describe_errno(errno),
                "check that the folder exists and is writable");
  }
  try {
    write_all(fd, bytes, path);
    if (sync && ::fsync(fd) != 0 && errno != EINVAL) {
      throw Error(path.string() + ": cannot write: " + describe_errno(errno) + " (nothing was kept)");
    }
  } catch (...) {
    ::close(fd);
    throw;
  }
  if (::close(fd) != 0) throw Error(path.string() + ": cannot write: " + describe_errno(errno) + " (nothing was kept)");
  temporary.commit();
}

}  // namespace fissure
