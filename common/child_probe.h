#pragma once
/// Runs a function in a forked child process and reports whether it finished. For
/// reading damaged input through a library that can crash or hang on it, where Fissure
/// cannot check the bytes first: assimp's readers (bake/mesh_import.cpp) and HDF5 1.10
/// reading a legacy container without checksums (formats/bundle.cpp). A crash, a hang
/// or a runaway allocation in the child becomes a clean error in the parent.
///
/// The child runs `probe` and leaves with _exit, so it flushes nothing and runs no
/// atexit handler of the parent's. POSIX only.

#include <cstdint>
#include <functional>
#include <string>

namespace fissure {

/// What the child may use. Zero: no limit of that kind.
struct ChildProbeLimits {
  double wall_seconds = 0;           ///< killed (SIGKILL) by the parent after this long
  double cpu_seconds = 0;            ///< RLIMIT_CPU in the child (SIGXCPU, then SIGKILL)
  std::uint64_t memory_bytes = 0;    ///< address space the child may add to what it inherits (RLIMIT_AS)
};

struct ChildProbeOutcome {
  bool finished = false;  ///< `probe` returned or threw; false: a signal, a sanitizer exit or a limit
  bool timed_out = false;      ///< killed for running past `wall_seconds` or `cpu_seconds`
  bool out_of_memory = false;  ///< stopped by the memory limit (bad_alloc, or a signal after a failed allocation)
  std::string how;        ///< "killed by signal 11 (Segmentation fault)", "exited with status 1", "ran past 5 s"
  /// When `probe` threw fissure::Error in the child: its message and hint, so the caller
  /// can report it without repeating the work (empty otherwise).
  std::string error, error_hint;
};

/// Throws fissure::Error when it cannot fork.
ChildProbeOutcome run_in_child(const std::function<void()>& probe, const ChildProbeLimits& limits = {});

/// True inside a probe's child: a nested probe of the same input would only repeat it.
bool inside_child_probe();

}  // namespace fissure
