#pragma once
/// Runs a function in a forked child process and reports whether it finished. For
/// reading damaged input through a library that can crash on it, where Fissure cannot
/// check the bytes first: HDF5 1.10 reading a legacy container without checksums
/// (formats/bundle.cpp). A crash in the child becomes a clean error in the parent.
///
/// The child runs `probe` and leaves with _exit, so it flushes nothing and runs no
/// atexit handler of the parent's. POSIX only.

#include <functional>
#include <string>

namespace fissure {

struct ChildProbeOutcome {
  bool finished = false;  ///< `probe` returned or threw; false: a signal or a sanitizer exit
  std::string how;        ///< "killed by signal 11 (Segmentation fault)", "exited with status 1"
};

/// Throws fissure::Error when it cannot fork.
ChildProbeOutcome run_in_child(const std::function<void()>& probe);

/// True inside a probe's child: a nested probe of the same input would only repeat it.
bool inside_child_probe();

}  // namespace fissure
