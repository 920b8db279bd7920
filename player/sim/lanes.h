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

/// Calls body(first, size) for each batch [first, first + size) of kLanes items of
/// [0, count) (the last one may be short), in parallel, `grain` items or more per task.
/// Batches start at multiples of kLanes whatever the threads, so which items share a
/// batch (and so the results) never depends on the thread count.
template <typename Index, typename Body>
void parallel_for_batches(Index count, Index grain, const Body& body) {
  const Index batches = (count + kLanes - 1) / kLanes;
  const Index grain_batches = std::max<Index>(1, grain / kLanes);
  tbb::parallel_for(tbb::blocked_range<Index>(0, batches, grain_batches), [&](const tbb::blocked_range<Index>& range) {
    for (Index batch = range.begin(); batch != range.end(); ++batch) {
      const Index first = batch * kLanes;
      body(first, static_cast<int>(std::min<Index>(kLanes, count - first)));
    }
  });
}

}  // namespace fissure::sim
