// A lag named on a roller whose drive droops must beat the drive's own lag behind the force, at
// every value the drive's quantised speed allows (core/gap/droop_lag.cpp).
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "core/gap/channels.hpp"
#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"
#include "sim/referee.hpp"
#include "sim/second/generator.hpp"
#include "tests/unit/station_test_util.hpp"

namespace {

using namespace brakefit;

/// The gates generator B's every-station null sets calibrate on the roller.
gap::Options every_station_gates() {
  gap::Options o = gap::calibrated_options(gap::Condition::Roller);
  o.gate_gain = 0.169;
  o.bic_margin = 10.0;
  o.bic_margin_per_point = 0.3504;
  o.noise_factor = 5.92;
  return o;
}

bool any_note_has(const gap::Report& rep, const std::string& text) {
  return std::any_of(rep.notes.begin(), rep.notes.end(),
                     [&](const std::string& n) { return n.find(text) != std::string::npos; });
}

}  // namespace

TEST(DroopLag, ANullSetsLagIsTheDrivesNotTheChannels) {
  // Seed 1086 of the every-station draw: a car's six runs at 2.0 km/h, no effect, its drive
  // drooping behind 0.30 s, read at 0.40 s from the transitions. The misread lag moved the slip
  // as a channel 3 ms early would: a time offset of -3 ms gained 0.28 over the baseline.
  const auto set = sim2::draw_set(can::BenchKind::Roller, "none", 0.0, 1086, sim2::Stations::Every);
  const std::vector<gap::Run> runs = test::conditioned(set, false);
  const auto alts = gap::droop_lag_alternatives(runs);
  ASSERT_FALSE(alts.empty());
  for (const auto& a : alts) {
    EXPECT_NE(a.lag_s, runs.front().roller_droop_lag_s);
    EXPECT_EQ(a.runs.size(), runs.size());
  }
  const auto rep = gap::diagnose(runs, sim::pooled_start(runs), every_station_gates());
  EXPECT_EQ(rep.verdict, std::vector<std::string>{"none"});
  EXPECT_TRUE(any_note_has(rep, "cannot be told apart on these runs"));
}

TEST(DroopLag, ALateChannelOnTheSameStationIsStillNamed) {
  // The same station, its pressure channel 30 ms late: more than any lag the transitions allow.
  const auto set =
      sim2::draw_set(can::BenchKind::Roller, "time_offset", 0.03, 1086, sim2::Stations::Every);
  const std::vector<gap::Run> runs = test::conditioned(set, false);
  const auto rep = gap::diagnose(runs, sim::pooled_start(runs), every_station_gates());
  ASSERT_FALSE(rep.verdict.empty());
  EXPECT_TRUE(rep.verdict.front() == "time_offset" || rep.verdict.front() == "relaxation_length")
      << rep.verdict.front();
}

TEST(DroopLag, AHeldRollerHasNoOtherLag) {
  // Generator B's car sets: a roller held at 5 km/h, nothing drooping to read a lag from.
  const auto set =
      sim2::draw_set(can::BenchKind::Roller, "time_offset", 0.02, 7, sim2::Stations::Cars);
  EXPECT_TRUE(gap::droop_lag_alternatives(test::conditioned(set, false)).empty());
}
