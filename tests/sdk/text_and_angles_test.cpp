// The SDK's number-to-text rules and angle helpers.
#include <gtest/gtest.h>

#include <limits>

#include "hazardforge/angles.hpp"
#include "hazardforge/number_text.hpp"

namespace hf {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(NumberText, CompactNumbersForMessages) {
  EXPECT_EQ(num_text(12.0), "12");
  EXPECT_EQ(num_text(1.256), "1.26");
  EXPECT_EQ(num_text(1.5, 3), "1.5");
  EXPECT_EQ(num_text(-0.25), "-0.25");
  EXPECT_EQ(num_text(-0.001), "0");
  EXPECT_EQ(num_text(kInf), "inf");
  EXPECT_EQ(num_text(-kInf), "-inf");
  EXPECT_EQ(num_text(kNaN), "nan");
}

TEST(NumberText, FixedDecimalsKeepTheirZerosButNoSignOnZero) {
  EXPECT_EQ(fixed_text(3.1, 2), "3.10");
  EXPECT_EQ(fixed_text(2.0, 0), "2");
  EXPECT_EQ(fixed_text(-0.004, 2), "0.00");
  EXPECT_EQ(fixed_text(-0.006, 2), "-0.01");
  EXPECT_EQ(fixed_text(kNaN, 1), "nan");
}

TEST(NumberText, GeneralTextAsAStreamPrintsIt) {
  EXPECT_EQ(general_text(0.001), "0.001");
  EXPECT_EQ(general_text(1e6), "1e+06");
  EXPECT_EQ(general_text(20), "20");
}

TEST(Angles, WrapAndDifferenceTakeTheShorterWayRound) {
  EXPECT_NEAR(wrap_angle(3 * kPi / 2), -kPi / 2, 1e-12);
  EXPECT_NEAR(wrap_angle(-5 * kPi / 2), -kPi / 2, 1e-12);
  EXPECT_NEAR(angle_diff(deg_to_rad(-179), deg_to_rad(179)), deg_to_rad(2), 1e-12);
  EXPECT_NEAR(angle_diff(deg_to_rad(179), deg_to_rad(-179)), deg_to_rad(-2), 1e-12);
  EXPECT_NEAR(rad_to_deg(kPi), 180.0, 1e-12);
  EXPECT_DOUBLE_EQ(wrap_deg(190), -170);
  EXPECT_DOUBLE_EQ(wrap_deg(-180), 180);
  EXPECT_DOUBLE_EQ(wrap_deg(540), 180);
  EXPECT_DOUBLE_EQ(wrap_deg(-30), -30);
}

}  // namespace
}  // namespace hf
