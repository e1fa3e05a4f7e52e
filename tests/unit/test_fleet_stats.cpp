// The fleet report's control chart: a lane against the fleet, week by week.
#include <gtest/gtest.h>

#include "core/fleet/control_chart.hpp"

namespace {

using brakefit::fleetstats::control;
using brakefit::fleetstats::fleet_weeks;
using brakefit::fleetstats::WeekFigure;

constexpr std::int64_t kWeek = 7 * 86400;

std::vector<WeekFigure> lane(double base, double shifted_from_week, double shift, int weeks = 10) {
  std::vector<WeekFigure> w;
  for (int i = 0; i < weeks; ++i)
    w.push_back(
        {i * kWeek, 40, base + (i >= shifted_from_week ? shift : 0.0) + 0.002 * (i % 3), 0.08});
  return w;
}

TEST(FleetControl, ALaneReadingHighForTheLastWeeksDepartsSinceTheFirstOfThem) {
  std::map<std::string, std::vector<WeekFigure>> lanes;
  for (int k = 0; k < 6; ++k) lanes["lane" + std::to_string(k)] = lane(0.9 + 0.01 * k, 99, 0);
  lanes["hot"] = lane(0.92, 7, 0.15);
  const auto fleet = fleet_weeks(lanes);
  const auto v = control(lanes["hot"], fleet);
  EXPECT_TRUE(v.departs);
  EXPECT_EQ(v.direction, 1);
  EXPECT_EQ(v.since_unix_s, 7 * kWeek);
  EXPECT_NEAR(v.offset, 0.15, 0.03);
  for (int k = 0; k < 6; ++k)
    EXPECT_FALSE(control(lanes["lane" + std::to_string(k)], fleet).departs);
}

TEST(FleetControl, OneOddWeekOrAShiftWithinTheLanesSpreadIsNotFlagged) {
  std::map<std::string, std::vector<WeekFigure>> lanes;
  for (int k = 0; k < 6; ++k) lanes["lane" + std::to_string(k)] = lane(0.85 + 0.03 * k, 99, 0);
  lanes["odd"] = lane(0.92, 9, 0.3);      // only the last week
  lanes["within"] = lane(0.92, 5, 0.02);  // inside the lanes' own spread
  const auto fleet = fleet_weeks(lanes);
  EXPECT_FALSE(control(lanes["odd"], fleet).departs);
  EXPECT_FALSE(control(lanes["within"], fleet).departs);
  EXPECT_EQ(control(lanes["odd"], fleet).weeks_compared, 10);
}

TEST(FleetControl, ALowLaneSaysLow) {
  std::map<std::string, std::vector<WeekFigure>> lanes;
  for (int k = 0; k < 5; ++k) lanes["lane" + std::to_string(k)] = lane(0.9, 99, 0);
  lanes["low"] = lane(0.9, 4, -0.2);
  const auto v = control(lanes["low"], fleet_weeks(lanes));
  EXPECT_TRUE(v.departs);
  EXPECT_EQ(v.direction, -1);
  EXPECT_EQ(v.since_unix_s, 4 * kWeek);
}

}  // namespace
