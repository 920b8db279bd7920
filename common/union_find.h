#pragma once
/// Union-find over dense indices: the bake merges coincident positions with it, the
/// player finds fragments (tets connected through shared nodes).

#include <vector>

#include "common/types.h"

namespace fissure {

/// The root of i's set, halving the path on the way (each visited node then points at
/// its grandparent), so repeated queries stay near constant time.
inline Index find_root(std::vector<Index>& parent, Index i) {
  while (parent[i] != i) {
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}

}  // namespace fissure
