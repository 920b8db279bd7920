#include "common/counting_sort.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>
#include <utility>

namespace fissure {
namespace {

TEST(CountingSort, EqualKeysKeepTheirOrder) {
  const std::vector<std::pair<int, int>> in{{2, 0}, {0, 1}, {2, 2}, {1, 3}, {0, 4}, {2, 5}};
  std::vector<std::pair<int, int>> out;
  stable_counting_sort(in, out, 3, [](const auto& e) { return e.first; });
  const std::vector<std::pair<int, int>> expected{{0, 1}, {0, 4}, {1, 3}, {2, 0}, {2, 2}, {2, 5}};
  EXPECT_EQ(out, expected);
}

TEST(CountingSort, TwoPassesOrderDistinctPairsAsAComparisonSortDoes) {
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> key(0, 49);
  std::set<std::pair<int, int>> distinct;
  while (distinct.size() < 400) distinct.insert({key(rng), key(rng)});
  std::vector<std::pair<int, int>> pairs(distinct.begin(), distinct.end());
  std::shuffle(pairs.begin(), pairs.end(), rng);
  std::vector<std::pair<int, int>> by_second, sorted;
  stable_counting_sort(pairs, by_second, 50, [](const auto& e) { return e.second; });
  stable_counting_sort(by_second, sorted, 50, [](const auto& e) { return e.first; });
  std::sort(pairs.begin(), pairs.end());
  EXPECT_EQ(sorted, pairs);
}

TEST(CountingSort, NothingToSortGivesNothing) {
  const std::vector<int> in;
  std::vector<int> out{7};
  stable_counting_sort(in, out, 0, [](int e) { return e; });
  EXPECT_TRUE(out.empty());
}

}  // namespace
}  // namespace fissure
