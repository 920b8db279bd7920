#pragma once
/// Command-line parsing shared by the benchmark programs.

#include <exception>
#include <string>

#include "common/error.h"

namespace fissure::testing {

/// `value` as an integer ≥ `minimum`, or fissure::Error naming `flag` with `hint`.
inline int parse_integer_option(const std::string& flag, const std::string& value, int minimum,
                                const std::string& hint) {
  std::size_t used = 0;
  int n = 0;
  try {
    n = std::stoi(value, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != value.size() || n < minimum) {
    throw Error(flag + " " + value + " is not an integer ≥ " + std::to_string(minimum), hint);
  }
  return n;
}

}  // namespace fissure::testing
