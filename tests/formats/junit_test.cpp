// JUnit XML for CI reporters: exact output for a small report, and text from bundles
// (paths, details) escaped so the document stays well-formed.
#include "formats/junit.h"

#include <gtest/gtest.h>

namespace fissure::formats {
namespace {

TEST(Junit, OneSuitePerBundleOneCasePerCheck) {
  const std::vector<JunitSuite> suites = {
      {"a.h5", {{"tets-positive", true, "2 tets"}, {"budget:size", false, "3 MiB exceeds the budget of 1 MiB"}}, ""},
      {"b.h5", {}, "b.h5: not an HDF5 file"},
  };
  EXPECT_EQ(junit_xml(suites),
            "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
            "<testsuites name=\"fissure-bake verify\" tests=\"3\" failures=\"1\" errors=\"1\">\n"
            "  <testsuite name=\"a.h5\" tests=\"2\" failures=\"1\" errors=\"0\">\n"
            "    <testcase classname=\"a.h5\" name=\"tets-positive\"><system-out>2 tets</system-out></testcase>\n"
            "    <testcase classname=\"a.h5\" name=\"budget:size\">\n"
            "      <failure message=\"3 MiB exceeds the budget of 1 MiB\"/>\n"
            "    </testcase>\n"
            "  </testsuite>\n"
            "  <testsuite name=\"b.h5\" tests=\"1\" failures=\"0\" errors=\"1\">\n"
            "    <testcase classname=\"b.h5\" name=\"read\">\n"
            "      <error message=\"b.h5: not an HDF5 file\"/>\n"
            "    </testcase>\n"
            "  </testsuite>\n"
            "</testsuites>\n");
}

TEST(Junit, MarkupAndControlBytesAreEscapedOrDropped) {
  EXPECT_EQ(xml_escape("a<b>&\"c\"'d'"), "a&lt;b&gt;&amp;&quot;c&quot;&apos;d&apos;");
  EXPECT_EQ(xml_escape(std::string("x\0y\x1b\tz\n", 7)), "xy\tz\n");
  EXPECT_EQ(xml_escape("Σβ − 1"), "Σβ − 1");  // UTF-8 passes through
}

}  // namespace
}  // namespace fissure::formats
