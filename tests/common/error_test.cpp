// Messages quote bytes taken from files so that any bytes leave a whole, readable line.
#include "common/error.h"

#include <gtest/gtest.h>

#include <string>

namespace fissure {
namespace {

TEST(QuoteFromFile, PrintableTextIsKeptAndEveryOtherByteIsEscaped) {
  EXPECT_EQ(quote_from_file("end_header"), "'end_header'");
  EXPECT_EQ(quote_from_file(std::string("a\0b", 3)), "'a\\x00b'");
  EXPECT_EQ(quote_from_file("tab\there\n"), "'tab\\x09here\\x0a'");
  EXPECT_EQ(quote_from_file("\x1b[31m\xff"), "'\\x1b[31m\\xff'");
  // A backslash and the quote itself are escaped too, so the quoted text is unambiguous.
  EXPECT_EQ(quote_from_file("a\\'b"), "'a\\x5c\\x27b'");
  EXPECT_EQ(quote_from_file("say \"x\"", 40, '"'), "\"say \\x22x\\x22\"");
}

TEST(QuoteFromFile, LongTextIsCutWithAnEllipsis) {
  EXPECT_EQ(quote_from_file(std::string(100, 'x'), 4), "'xxxx'...");
  EXPECT_EQ(quote_from_file("xxxx", 4), "'xxxx'");
  EXPECT_EQ(quote_from_file(""), "''");
}

}  // namespace
}  // namespace fissure
