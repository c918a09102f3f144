// The number parser shared by the readers and the command line (src/detail/number.hpp), and its
// use by the ICP rejection rule. Oracle: values written exactly in the test.
#include "detail/number.hpp"

#include <gtest/gtest.h>

#include <limits>
#include <optional>
#include <stdexcept>

#include "align3d/icp/rejection.hpp"

namespace align3d {
namespace {

TEST(ParseFinite, AcceptsFiniteNumbersWithSurroundingSpaces) {
  EXPECT_EQ(detail::parse_finite("1.5"), 1.5);
  EXPECT_EQ(detail::parse_finite(" -2e3\t"), -2000.0);
  EXPECT_EQ(detail::parse_finite("+0.25"), 0.25);
  EXPECT_EQ(detail::parse_finite(".5"), 0.5);
  EXPECT_EQ(detail::parse_finite("1e-320"), 1e-320);  // subnormal, not out of range
  EXPECT_EQ(detail::parse_finite("0.1"), 0.1);        // correctly rounded
}

TEST(ParseFinite, RefusesAnythingElse) {
  for (const char* text : {"", " ", "nan", "-inf", "inf", "1e999", "1x", "1,5", "1 2", "0x10",
                           "+-1", "--1", "one", "1.5.", "e5"}) {
    EXPECT_EQ(detail::parse_finite(text), std::nullopt) << "'" << text << "'";
  }
}

TEST(ParseNumber, ReadsNaNAndInfinityForTheReadersToDrop) {
  double v = 0;
  EXPECT_TRUE(detail::parse_number("nan", v));
  EXPECT_TRUE(std::isnan(v));
  EXPECT_TRUE(detail::parse_number("-inf", v));
  EXPECT_EQ(v, -std::numeric_limits<double>::infinity());
  EXPECT_FALSE(detail::parse_number(" 1", v));  // the readers hand over whole tokens
  EXPECT_FALSE(detail::parse_number("", v));
}

TEST(ParseRejectionRule, UsesTheSharedParser) {
  EXPECT_EQ(parse_rejection_rule("distance: 2.5").distance, 2.5);
  EXPECT_EQ(parse_rejection_rule("median:3:+0.5").floor, 0.5);
  for (const char* rule : {"distance:nan", "distance:inf", "distance:0", "median:-1", "median:2:x",
                           "distance:1e999", "distance:"}) {
    EXPECT_THROW(parse_rejection_rule(rule), std::invalid_argument) << rule;
  }
}

}  // namespace
}  // namespace align3d
