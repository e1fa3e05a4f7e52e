// The smallest magnitude of each effect a set's runs could show (core/gap/reach.cpp): given
// where the effect is not named, so that "none" is read against what the runs could tell.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"
#include "sim/referee.hpp"
#include "sim/second/generator.hpp"
#include "tests/unit/referee_pair_test_util.hpp"

using namespace brakefit;

namespace {

std::vector<gap::Run> null_runs(can::BenchKind bench, std::uint64_t seed) {
  const auto set = sim2::draw_set(bench, {}, seed);
  std::vector<gap::Run> runs;
  for (std::size_t k = 0; k < set.runs.size(); ++k)
    sim::append_event_csv_runs(runs, sim2::simulate_event_csv(set.runs[k]), fmt::format("r{}", k));
  return runs;
}

gap::Report diagnosed(const std::vector<gap::Run>& runs, gap::Condition c) {
  return gap::diagnose(runs, sim::pooled_start(runs), gap::calibrated_options(c));
}

double reach_of(const std::vector<gap::EffectReach>& reach, gap::Effect e) {
  for (const auto& r : reach)
    if (r.effect == e) return r.smallest;
  return NAN;
}

}  // namespace

TEST(GapReach, TheRollerHidesAnInertiaTheRoadShows) {
  // At 5 km/h the wheel decelerates little before it runs away, and the curve's B, C, D, E take
  // most of what it does; on the road it decelerates with the vehicle.
  const auto roller = diagnosed(null_runs(can::BenchKind::Roller, 77), gap::Condition::Roller);
  const auto ground = diagnosed(null_runs(can::BenchKind::Ground, 77), gap::Condition::Ground);
  ASSERT_EQ(roller.verdict, std::vector<std::string>{"none"});
  const double on_roller = reach_of(roller.reach, gap::Effect::WheelInertia);
  const double on_ground = reach_of(ground.reach, gap::Effect::WheelInertia);
  ASSERT_TRUE(std::isfinite(on_roller)) << on_roller;
  ASSERT_TRUE(std::isfinite(on_ground)) << on_ground;
  EXPECT_GT(on_ground, 0.0);
  EXPECT_GT(on_roller, 3 * on_ground) << on_roller << " vs " << on_ground;
  // Every one-parameter candidate has one (a cradle cap and load transfer have none), and the
  // note gives them in their parameters' units.
  for (auto e : {gap::Effect::RelaxationLength, gap::Effect::TimeOffset,
                 gap::Effect::BrakeThreshold, gap::Effect::SlipOffset, gap::Effect::SpeedFriction})
    EXPECT_GT(reach_of(roller.reach, e), 0.0) << gap::to_string(e);
  // A slip offset is the nuisance slip bias beyond its bound: it shows past that bound, not
  // never (both add to the same slip).
  const double offset = reach_of(roller.reach, gap::Effect::SlipOffset);
  EXPECT_GE(offset, gap::nuisance_bias_bound(gap::pointers(null_runs(can::BenchKind::Roller, 77)),
                                             {gap::Effect::SlipOffset}));
  EXPECT_LT(offset, 0.005);
  EXPECT_TRUE(std::isnan(reach_of(roller.reach, gap::Effect::CradleCap)));
  EXPECT_TRUE(std::isnan(reach_of(ground.reach, gap::Effect::LoadTransfer)));
  EXPECT_TRUE(std::any_of(roller.notes.begin(), roller.notes.end(), [](const std::string& n) {
    return n.find("wheel_inertia inertia_kgm2 from") != std::string::npos;
  }));
}

TEST(GapReach, GrowsWithTheFloorAndTheGateAndIsInfiniteWithoutDeceleration) {
  const auto runs = null_runs(can::BenchKind::Roller, 78);
  const auto rep = diagnosed(runs, gap::Condition::Roller);
  const auto at = [&](const std::vector<gap::Run>& rs, double noise_n, double gate) {
    return reach_of(gap::effect_reach(rs, rep.before.params, rep.baseline_effects,
                                      {gap::Effect::WheelInertia}, noise_n, gate),
                    gap::Effect::WheelInertia);
  };
  const double base = at(runs, rep.noise_n, 0.1);
  ASSERT_TRUE(std::isfinite(base));
  EXPECT_NEAR(at(runs, 2 * rep.noise_n, 0.1), 2 * base, 1e-9 * base);
  EXPECT_GT(at(runs, rep.noise_n, 0.2), base);
  // A wheel that never decelerates holds no inertia's force: no inertia could be shown.
  auto still = runs;
  for (auto& r : still) std::fill(r.wheel_accel_mps2.begin(), r.wheel_accel_mps2.end(), 0.0);
  EXPECT_TRUE(std::isinf(at(still, rep.noise_n, 0.1)));
  // Nor under a gate that passes everything or nothing.
  EXPECT_TRUE(std::isnan(at(runs, rep.noise_n, 0.0)));
  EXPECT_TRUE(std::isnan(at(runs, rep.noise_n, 1.0)));
}

TEST(GapReach, AnEffectNamedHasNoReach) {
  auto set = sim2::draw_set(can::BenchKind::Ground, {{"wheel_inertia", 2.0}}, 79);
  std::vector<gap::Run> runs;
  for (std::size_t k = 0; k < set.runs.size(); ++k)
    sim::append_event_csv_runs(runs, sim2::simulate_event_csv(set.runs[k]), fmt::format("r{}", k));
  const auto rep = diagnosed(runs, gap::Condition::Ground);
  ASSERT_FALSE(rep.verdict.empty());
  ASSERT_EQ(rep.verdict.front(), "wheel_inertia");
  EXPECT_TRUE(std::isnan(reach_of(rep.reach, gap::Effect::WheelInertia)));
  EXPECT_GT(reach_of(rep.reach, gap::Effect::SlipOffset), 0.0);
}

TEST(GapReach, IsReadBesideTheEffectsNamed) {
  // A 2.2 kg m^2 wheel behind a 44 ms late pressure channel: the channel never shows the wheel's
  // last 44 ms before the runs end, where its inertia's force is. Against the baseline alone the
  // reach read 0.5 kg m^2, as if the inertia should have shown; beside the named time offset it
  // is above the truth, and the note says what it was read beside.
  sim::Injection inj{"wheel_inertia", 2.22, gap::Condition::Roller, sim::Generator::B};
  inj.effect2 = "time_offset";
  inj.magnitude2 = 0.0438;
  const auto t = sim::run_trial(inj, 701009, gap::calibrated_options(gap::Condition::Roller));
  ASSERT_EQ(t.verdict, std::vector<std::string>{"time_offset"});
  EXPECT_GT(t.reach, 2.22);
  EXPECT_TRUE(std::isnan(t.reach2));  // named: no reach
  EXPECT_TRUE(std::any_of(t.notes.begin(), t.notes.end(), [](const std::string& n) {
    return n.find("C, D, E and the named time_offset take") != std::string::npos;
  }));
}

TEST(GapReach, WhatTheNuisanceBiasTakesDoesNotShow) {
  // Every export's roller trial 3: a car's 1.3 bar dead zone on a drooping, quantised roller
  // (2.1 mm/s steps at 3.2 km/h, half a step 1.2e-3 of slip). The baseline's nuisance slip bias
  // takes it as a foot shift of 1.5e-3 (the tyre's own and the reference's bound, 1.7e-3) and
  // leaves the floor: nothing is named. Read against the basis without the bias the reach was
  // 0.14 bar, as if the threshold should have shown; the bias takes about 1.9 bar of it first.
  const auto t = test::every_export_roller_trial(3);
  ASSERT_EQ(t.truth.effect, "brake_threshold");
  ASSERT_EQ(t.verdict, std::vector<std::string>{"none"}) << test::why_of(t);
  EXPECT_GT(t.reach, t.truth.magnitude) << test::why_of(t);
  EXPECT_LT(t.reach, 3 * t.truth.magnitude) << test::why_of(t);
}
