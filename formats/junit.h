#pragma once
/// JUnit XML, the test-report format GitLab, Jenkins and GitHub's test reporters read:
/// `fissure-bake verify --junit` writes one test suite per bundle, one test case per
/// check, so a CI page lists exactly which invariant or budget failed on which asset.

#include <algorithm>
#include <string>
#include <vector>

#include "formats/bundle_checks.h"

namespace fissure::formats {

struct JunitSuite {
  std::string name;                  ///< the bundle, as named on the command line
  std::vector<VerifyCheck> cases;    ///< one <testcase> each; a failed one carries <failure>
  std::string error;                 ///< non-empty: the bundle could not be read at all (<error>)
  /// Read, and every check passed.
  [[nodiscard]] bool passed() const {
    return error.empty() && std::all_of(cases.begin(), cases.end(), [](const VerifyCheck& c) { return c.passed; });
  }
};

std::string junit_xml(const std::vector<JunitSuite>& suites);

/// Text made safe for an XML attribute or element: & < > " ' escaped, and bytes XML 1.0
/// cannot hold (control characters but tab and newline) dropped.
std::string xml_escape(const std::string& text);

}  // namespace fissure::formats
