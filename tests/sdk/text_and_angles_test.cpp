// The SDK's number-to-text rules, angle helpers and the ego track's heading change.
#include <gtest/gtest.h>

#include <limits>

#include "hazardforge/angles.hpp"
#include "hazardforge/number_text.hpp"
#include "hazardforge/types.hpp"

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

EgoTrack track_with_yaws(const std::vector<double>& yaw_deg) {
  EgoTrack tr;
  for (size_t i = 0; i < yaw_deg.size(); ++i) {
    EgoTrackSample s;
    s.t = 0.5 * static_cast<double>(i);
    s.yaw = deg_to_rad(yaw_deg[i]);
    tr.samples.push_back(s);
  }
  return tr;
}

TEST(EgoTrack, AHeadingCrossingPlusMinus180IsNoTurn) {
  // Headings as a dataset stores them, in [-180, 180]: a gentle left bend from 170 to -170 deg is 20 deg.
  const EgoTrack tr = track_with_yaws({170, 175, 179, -177, -172, -170});
  EXPECT_NEAR(rad_to_deg(tr.heading_change(0.0, 2.5)), 20.0, 1e-9);
  EXPECT_NEAR(rad_to_deg(tr.heading_change(2.5, 0.0)), -20.0, 1e-9);
  // Between samples the heading is interpolated the shorter way round.
  EXPECT_NEAR(rad_to_deg(tr.heading_change(1.0, 1.25)), 2.0, 1e-9);
}

TEST(EgoTrack, ABendOfMoreThanHalfATurnCountsInFull) {
  const EgoTrack tr = track_with_yaws({0, 60, 120, 180, -120, -60, 0, 30});
  EXPECT_NEAR(rad_to_deg(tr.heading_change(0.0, 3.5)), 390.0, 1e-9);
  EXPECT_NEAR(rad_to_deg(tr.heading_change(-1.0, 0.0)), 0.0, 1e-9);  // clamped to the samples
}

}  // namespace
}  // namespace hf
