#pragma once
/// A stable counting sort by a small integer key: the player orders its system's terms
/// and its collision pairs with it, two passes each (least significant key first).

#include <cstddef>
#include <vector>

namespace fissure {

/// `out` = `in` ordered by key(element), a value in [0, keys); elements with the same
/// key keep their order in `in`. O(in.size() + keys). Sorting by the second key and
/// then the first orders by (first, second), as a comparison sort of distinct pairs would.
template <typename T, typename Key>
void stable_counting_sort(const std::vector<T>& in, std::vector<T>& out, std::size_t keys, Key key) {
  std::vector<std::size_t> start(keys + 1, 0);
  for (const T& e : in) ++start[static_cast<std::size_t>(key(e)) + 1];
  for (std::size_t k = 0; k < keys; ++k) start[k + 1] += start[k];
  out.resize(in.size());
  for (const T& e : in) out[start[static_cast<std::size_t>(key(e))]++] = e;
}

}  // namespace fissure
