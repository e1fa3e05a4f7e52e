// A station's drooping roller drive (generator B's every-export draws): rebuilt with its droop,
// one droop shared by a station's runs, and neither read as an effect nor seen on a held roller.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"
#include "sim/referee.hpp"
#include "sim/second/generator.hpp"
#include "tests/unit/station_test_util.hpp"

using namespace brakefit;

namespace {

/// RMS of a run's rebuilt roller speed against the ideal encoders' run (the nearest sample at
/// or after each time).
double speed_rms_mps(const gap::Run& q, const gap::Run& truth) {
  double se = 0;
  std::size_t j = 0;
  for (std::size_t i = 0; i < q.t_s.size(); ++i) {
    while (j + 1 < truth.t_s.size() && truth.t_s[j] < q.t_s[i]) ++j;
    se += std::pow(q.v_ref_mps[i] - truth.v_ref_mps[j], 2);
  }
  return std::sqrt(se / static_cast<double>(q.t_s.size()));
}

}  // namespace

TEST(Stations, ADroopingRollerIsRebuiltWithItsDroop) {
  // Seed 1000003 of the every-station draw: a car on a 5.8 km/h roller in 1.5 mm/s steps, its
  // drive drooping by several steps under the brake. Rebuilt piecewise between its transitions,
  // the roller's speed was 0.3-0.5 mm/s off and the null set `unexplained` (gap 4.6x the floor).
  const auto set =
      sim2::draw_set(can::BenchKind::Roller, "none", 0, 1000003, sim2::Stations::Every);
  ASSERT_GT(set.runs.front().roller_droop_ratio, 0.005);
  const auto q = test::conditioned(set, false), truth = test::conditioned(set, true);
  ASSERT_EQ(q.size(), truth.size());
  for (std::size_t k = 0; k < q.size(); ++k) {
    double se = 0, span = 0;
    for (std::size_t i = 0; i < q[k].t_s.size(); ++i) {
      std::size_t j = 0;
      while (j + 1 < truth[k].t_s.size() && truth[k].t_s[j] < q[k].t_s[i]) ++j;
      se += std::pow(q[k].v_ref_mps[i] - truth[k].v_ref_mps[j], 2);
      span = std::max(span, truth[k].v_ref_mps.front() - truth[k].v_ref_mps[j]);
    }
    const double rms = std::sqrt(se / static_cast<double>(q[k].t_s.size()));
    EXPECT_GT(span, set.runs.front().tester.speed_step_mps) << "run " << k << " droops";
    EXPECT_LT(rms, 0.15 * set.runs.front().tester.speed_step_mps) << "run " << k;
  }
}

TEST(Stations, AStationsRunsAreRebuiltWithOneDroop) {
  // Seed 1000000 of the every-station draw: a car on a 4.1 km/h roller in 1.5 mm/s steps whose
  // drive loses 0.64 mm/s per kN behind 0.37 s, five runs. Fitted alone, three short runs (1-5
  // transitions each) read no lag and half the droop, and the null set said `unexplained` (gap
  // 4.4x the floor). Fitted together (one drive), the worst run's speed is 0.21 mm/s off the
  // drive's (0.35 alone), and the null set says `none` (1.1x the floor).
  const auto set =
      sim2::draw_set(can::BenchKind::Roller, "none", 0, 1000000, sim2::Stations::Every);
  ASSERT_GT(set.runs.front().roller_droop_ratio, 0.001);
  auto q = test::conditioned(set, false);
  const auto truth = test::conditioned(set, true);
  ASSERT_EQ(q.size(), truth.size());
  const double step = set.runs.front().tester.speed_step_mps;
  auto worst_rms = [&](const std::vector<gap::Run>& runs) {
    double worst = 0;
    for (std::size_t k = 0; k < runs.size(); ++k)
      worst = std::max(worst, speed_rms_mps(runs[k], truth[k]));
    return worst;
  };
  const double alone = worst_rms(q);
  const std::string note = gap::share_roller_droop(q);
  EXPECT_NE(note.find("together"), std::string::npos) << note;
  const double together = worst_rms(q);
  EXPECT_LT(together, 0.75 * alone) << "alone " << alone << " m/s, together " << together;
  EXPECT_LT(together, 0.25 * step);
  const auto runs = test::conditioned(set, false);
  const auto rep =
      gap::diagnose(runs, sim::pooled_start(runs), gap::calibrated_options(gap::Condition::Roller));
  EXPECT_EQ(rep.verdict, std::vector<std::string>{"none"});
  EXPECT_LT(rep.gap_before_rmse_n, 1.5 * rep.noise_n);
}

TEST(Stations, ANullSetOnADroopingRollerSaysNone) {
  // The same set diagnosed: with the roller's speed rebuilt with its droop, nothing is left.
  const auto set =
      sim2::draw_set(can::BenchKind::Roller, "none", 0, 1000003, sim2::Stations::Every);
  const auto q = test::conditioned(set, false);
  const auto rep =
      gap::diagnose(q, sim::pooled_start(q), gap::calibrated_options(gap::Condition::Roller));
  EXPECT_EQ(rep.verdict, std::vector<std::string>{"none"});
}

TEST(Stations, ARollersDroopIsNotReadAsLoadTransfer) {
  // Seed 1000013 of the every-station draw: a truck wheel on a 2.6 km/h roller whose drive slows
  // under the brake. The roller's deceleration follows the force; a load transfer read from it
  // reshaped the curve with the force (held-out gain 0.14 on this null set, which set the gates
  // every weak effect on such rollers was held to). The vehicle stands on the rollers: no load
  // transfer is a candidate there, and the null set's best candidate stays under the shipped gate.
  const auto set =
      sim2::draw_set(can::BenchKind::Roller, "none", 0, 1000013, sim2::Stations::Every);
  ASSERT_GT(set.runs.front().roller_droop_ratio, 0.005);
  const auto q = test::conditioned(set, false);
  double decel_max = 0;
  for (const auto& r : q)
    for (double a : r.ref_decel_mps2) decel_max = std::max(decel_max, a);
  ASSERT_GT(decel_max, 0.0) << "the roller's drive droops: its deceleration is there to read";
  auto probe = gap::calibrated_options(gap::Condition::Roller);
  probe.gate_gain = 1e9;  // name nothing: every candidate's score is wanted
  const auto rep = gap::diagnose(q, sim::pooled_start(q), probe);
  ASSERT_FALSE(rep.effects.empty());
  double best = -1;
  for (const auto& e : rep.effects) {
    EXPECT_NE(e.effect, gap::Effect::LoadTransfer);
    best = std::max(best, e.gain);
  }
  EXPECT_LT(best, gap::calibrated_options(gap::Condition::Roller).gate_gain);
}

TEST(Stations, AHeldRollerIsNotReadAsDrooping) {
  // Generator B's car sets hold their roller at speed: no droop is fitted (a droop fitted to
  // dithered levels would bend the slip).
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    const auto set = sim2::draw_set(can::BenchKind::Roller, "none", 0, seed);
    const auto runs = test::conditioned(set, false);
    for (const auto& r : runs) {
      const auto [lo, hi] = std::minmax_element(r.v_ref_mps.begin(), r.v_ref_mps.end());
      EXPECT_LT(*hi - *lo, 0.5 * set.runs.front().tester.speed_step_mps) << "seed " << seed;
    }
  }
}

TEST(Stations, AShortRunTakesTheDroopItsStationsLongerRunsShow) {
  // Seed 1022 of the every-station draw: a car on a 2.6 km/h roller in 1.7 mm/s steps. The two
  // long runs' staircases step with the droop and it is fitted there; in the two short, fast
  // stops the drive droops 1.1 mm/s, within a step, and the channel stays on one level: read as
  // held, their speed's shape was 0.2-0.3 of a step off (a null set's gap 24 N against a 2 N
  // floor); with the droop of the long runs, under 0.05.
  const auto set = sim2::draw_set(can::BenchKind::Roller, "none", 0, 1022, sim2::Stations::Every);
  auto q = test::conditioned(set, false);
  const auto truth = test::conditioned(set, true);
  ASSERT_EQ(q.size(), truth.size());
  const double step = set.runs.front().tester.speed_step_mps;
  // The speed's shape: its error less the mean error (a run's level, within half a step, is the
  // diagnosis's to level at zero force).
  auto rms_error = [&](const gap::Run& r, const gap::Run& t) {
    std::vector<double> d;
    for (std::size_t i = 0; i < r.t_s.size(); ++i) {
      std::size_t j = 0;
      while (j + 1 < t.t_s.size() && t.t_s[j] < r.t_s[i]) ++j;
      d.push_back(r.v_ref_mps[i] - t.v_ref_mps[j]);
    }
    double mean = 0, se = 0;
    for (double x : d) mean += x / static_cast<double>(d.size());
    for (double x : d) se += (x - mean) * (x - mean);
    return std::sqrt(se / static_cast<double>(d.size()));
  };
  int held = 0;
  for (std::size_t k = 0; k < q.size(); ++k) {
    if (!q[k].roller_held_quantised) continue;
    ++held;
    EXPECT_GT(rms_error(q[k], truth[k]), 0.15 * step) << "run " << k << " before";
  }
  ASSERT_GE(held, 1);
  const std::string note = gap::share_roller_droop(q);
  EXPECT_NE(note.find("droops under the brake's force"), std::string::npos) << note;
  for (std::size_t k = 0; k < q.size(); ++k)
    EXPECT_LT(rms_error(q[k], truth[k]), 0.08 * step) << "run " << k;
}

TEST(Stations, ASlowRunSteppingOnceATurnIsNotGivenARipple) {
  // Seed 1176 of the every-station draw: a car on a 4.8 km/h roller in 1.1 mm/s steps whose
  // drive droops behind 0.28 s; its slowest run (12 s) steps 25 times over 24 turns of the
  // roller. The roller's ripple fitted to those transitions read 2.5 mm/s (its encoder's 0.35),
  // and that run's level, pinned at its rest by the phantom, sat 1.3 mm/s high: its slip was
  // 1e-3 off, 110 N across the linear region (gap 12.8x the floor).
  const auto set = sim2::draw_set(can::BenchKind::Roller, "none", 0, 1176, sim2::Stations::Every);
  ASSERT_GT(set.runs.front().roller_droop_ratio, 0.005);
  auto q = test::conditioned(set, false);
  const auto truth = test::conditioned(set, true);
  ASSERT_EQ(q.size(), truth.size());
  const double step = set.runs.front().tester.speed_step_mps;
  const std::string note = gap::share_roller_droop(q);
  ASSERT_NE(note.find("together"), std::string::npos) << note;
  double longest_s = 0;
  for (std::size_t k = 0; k < q.size(); ++k) {
    longest_s = std::max(longest_s, q[k].t_s.back() - q[k].t_s.front());
    EXPECT_LT(speed_rms_mps(q[k], truth[k]), 0.5 * step) << "run " << k;
  }
  EXPECT_GT(longest_s, 10.0) << "the set holds the slow run";
}
