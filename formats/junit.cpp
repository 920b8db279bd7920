#include "formats/junit.h"

#include <algorithm>

namespace fissure::formats {

std::string xml_escape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default:
        if (static_cast<unsigned char>(c) >= 0x20 || c == '\t' || c == '\n') out += c;
    }
  }
  return out;
}

std::string junit_xml(const std::vector<JunitSuite>& suites) {
  std::size_t tests = 0, failures = 0, errors = 0;
  std::string body;
  for (const JunitSuite& suite : suites) {
    const std::size_t suite_failures =
        static_cast<std::size_t>(std::count_if(suite.cases.begin(), suite.cases.end(), [](const VerifyCheck& c) { return !c.passed; }));
    const std::size_t suite_tests = suite.cases.size() + (suite.error.empty() ? 0 : 1);
    const std::size_t suite_errors = suite.error.empty() ? 0 : 1;
    tests += suite_tests;
    failures += suite_failures;
    errors += suite_errors;
    const std::string name = xml_escape(suite.name);
    body += "  <testsuite name=\"" + name + "\" tests=\"" + std::to_string(suite_tests) + "\" failures=\"" +
            std::to_string(suite_failures) + "\" errors=\"" + std::to_string(suite_errors) + "\">\n";
    if (!suite.error.empty()) {
      body += "    <testcase classname=\"" + name + "\" name=\"read\">\n      <error message=\"" + xml_escape(suite.error) +
              "\"/>\n    </testcase>\n";
    }
    for (const VerifyCheck& check : suite.cases) {
      body += "    <testcase classname=\"" + name + "\" name=\"" + xml_escape(check.name) + "\">";
      if (check.passed) {
        body += "<system-out>" + xml_escape(check.detail) + "</system-out></testcase>\n";
      } else {
        body += "\n      <failure message=\"" + xml_escape(check.detail) + "\"/>\n    </testcase>\n";
      }
    }
    body += "  </testsuite>\n";
  }
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<testsuites name=\"fissure-bake verify\" tests=\"" +
         std::to_string(tests) + "\" failures=\"" + std::to_string(failures) + "\" errors=\"" + std::to_string(errors) +
         "\">\n" + body + "</testsuites>\n";
}

}  // namespace fissure::formats
