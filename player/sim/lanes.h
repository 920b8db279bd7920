#pragma once
/// Batches for the element loops' SIMD kernels: kLanes consecutive tets (or nodes), one
/// per lane of a register of doubles (AVX2 holds four). The kernels themselves are built
/// per instruction set with `target_clones`, so the same binary runs everywhere
/// (FISSURE_SIMD_KERNEL; one portable build where the clones are off or unsupported).

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstddef>

namespace fissure::sim {

inline constexpr int kLanes = 4;

#if defined(FISSURE_SIMD_CLONES)
#define FISSURE_SIMD_KERNEL __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define FISSURE_SIMD_KERNEL
#endif

/// A loop runs on the threads only when it makes at least this many tasks of its grain;
/// shorter ones run on the calling thread. Waking the other thread and joining it cost
/// more than a short loop's work: the sample's 987-tet bunny stepped faster on one
/// thread than on two until such loops ran on one, and then 0.87× as long as before
/// (docs/decisions/0077-short-loops-on-one-thread.md). The grains stay each loop's own,
/// so a large body's loops split as before.
inline constexpr int kFewestTasks = 4;

/// body(range) over [0, count) in ranges of `grain` items or more, on the threads when
/// count ≥ kFewestTasks × grain, else as one range on this thread. Every loop that uses
/// it gives results that do not depend on how [0, count) is split.
template <typename Index, typename Body>
void parallel_for_range(Index count, Index grain, const Body& body) {
  if (count < static_cast<Index>(kFewestTasks) * grain) {
    body(tbb::blocked_range<Index>(0, count));
    return;
  }
  tbb::parallel_for(tbb::blocked_range<Index>(0, count, grain), body);
}

/// Calls body(first, size) for each batch [first, first + size) of kLanes items of
/// [0, count) (the last one may be short), `grain` items or more per task
/// (parallel_for_range). Batches start at multiples of kLanes whatever the threads, so
/// which items share a batch (and so the results) never depends on the thread count.
template <typename Index, typename Body>
void parallel_for_batches(Index count, Index grain, const Body& body) {
  const Index batches = (count + kLanes - 1) / kLanes;
  const Index grain_batches = std::max<Index>(1, grain / kLanes);
  parallel_for_range<Index>(batches, grain_batches, [&](const tbb::blocked_range<Index>& range) {
    for (Index batch = range.begin(); batch != range.end(); ++batch) {
      const Index first = batch * kLanes;
      body(first, static_cast<int>(std::min<Index>(kLanes, count - first)));
    }
  });
}

}  // namespace fissure::sim
