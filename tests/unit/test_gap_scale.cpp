// The diagnosis on every export a station makes and on many runs (issue 34): a 100 Hz export is
// diagnosed like a 1 kHz one, and a set of many runs is held out in blocks, each run kept at a
// share of a fixed budget of points; two runs are each held out in blocks beside the other.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <string>
#include <vector>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"
#include "sim/referee.hpp"
#include "sim/second/generator.hpp"
#include "tests/unit/station_test_util.hpp"

using namespace brakefit;

namespace {

/// Generator B's set of `seed` exported at sample_hz, read back and conditioned as `brakefit gap`
/// does (events too short are left out, as there).
std::vector<gap::Run> b_set_at(can::BenchKind bench, const std::string& effect, double magnitude,
                               std::uint64_t seed, double sample_hz) {
  sim::Injection inj{
      effect, magnitude,
      bench == can::BenchKind::Roller ? gap::Condition::Roller : gap::Condition::Ground,
      sim::Generator::B};
  return sim::generator_b_runs(inj, seed, sample_hz);
}

}  // namespace

TEST(ExportRates, HundredHzNullSetsAreDiagnosedNotRefused) {
  // A ground stop at 250 bar/s from 70 km/h lasts a few tenths of a second: 30-60 samples at
  // 100 Hz. Every run must be kept and the set read as having no effect.
  for (auto bench : {can::BenchKind::Roller, can::BenchKind::Ground}) {
    for (std::uint64_t seed : {11u, 12u}) {
      const auto runs = b_set_at(bench, "none", 0, seed, 100);
      ASSERT_EQ(runs.size(), 3u) << can::to_string(bench) << " seed " << seed;
      const auto c =
          bench == can::BenchKind::Roller ? gap::Condition::Roller : gap::Condition::Ground;
      const auto rep = gap::diagnose(runs, sim::pooled_start(runs), gap::calibrated_options(c));
      EXPECT_EQ(rep.verdict, std::vector<std::string>{"none"})
          << can::to_string(bench) << " seed " << seed << ": gap " << rep.gap_before_rmse_n
          << " N, floor " << rep.noise_n << " N";
    }
  }
}

TEST(ExportRates, HundredHzRollerSetReadsTheThresholdTheKilohertzExportDoes) {
  // The same runs exported at 1 kHz and at 100 Hz: the effect named and its magnitude within 3 %
  // (the smoother spans at most 20 ms each side whatever the rate).
  double estimate[2] = {0, 0};
  int k = 0;
  for (double hz : {1000.0, 100.0}) {
    const auto runs = b_set_at(can::BenchKind::Roller, "brake_threshold", 3.0, 21, hz);
    ASSERT_EQ(runs.size(), 3u) << hz << " Hz";
    const auto rep = gap::diagnose(runs, sim::pooled_start(runs),
                                   gap::calibrated_options(gap::Condition::Roller));
    ASSERT_FALSE(rep.verdict.empty());
    EXPECT_EQ(rep.verdict.front(), "brake_threshold") << hz << " Hz";
    for (const auto& e : rep.effects)
      if (e.effect == gap::Effect::BrakeThreshold && e.accepted)
        estimate[k] = e.params.at(0).second;
    ++k;
  }
  ASSERT_GT(estimate[0], 0.5);
  EXPECT_NEAR(estimate[1], estimate[0], 0.03 * estimate[0]);
}

TEST(ManyRuns, PointsPerRunShareABudgetPastSixRuns) {
  EXPECT_EQ(gap::points_per_run(2), 400u);
  EXPECT_EQ(gap::points_per_run(6), 400u);
  EXPECT_EQ(gap::points_per_run(12), 200u);
  EXPECT_EQ(gap::points_per_run(24), 120u);  // the floor
  EXPECT_EQ(gap::points_per_run(200), 120u);
  EXPECT_DOUBLE_EQ(gap::relative_cost(3), 1.0);
  EXPECT_LT(gap::relative_cost(24), 10.0);
  EXPECT_GT(gap::relative_cost(200), gap::relative_cost(24));
}

TEST(ManyRuns, HeldOutInAtMostSixBlocksOfConsecutiveRuns) {
  // Runs whose force is their index: a fit on some runs returns their mean force as D (B, C, E
  // make a flat curve), so each held-out error says which runs it was fitted on.
  auto make = [](std::size_t n) {
    std::vector<gap::Run> runs(n);
    for (std::size_t i = 0; i < n; ++i) {
      runs[i].name = fmt::format("{}", i);
      runs[i].t_s = {0.0, 0.1};
      runs[i].v_ref_mps = {1.0, 1.0};
      runs[i].slip = {0.5, 0.5};
      runs[i].force_n = {static_cast<double>(i), static_cast<double>(i)};
    }
    return runs;
  };
  for (std::size_t n : {3u, 6u, 7u, 24u}) {
    const auto runs = make(n);
    std::vector<std::vector<std::size_t>> trained_on;
    const gap::Fitter fit = [&](const std::vector<const gap::Run*>& train,
                                const std::vector<gap::Effect>&) {
      std::vector<std::size_t> ids;
      ids.reserve(train.size());
      for (const auto* r : train) ids.push_back(static_cast<std::size_t>(std::stoul(r->name)));
      trained_on.push_back(ids);
      gap::Fit f;
      f.params = {1.0, 1.0, 0.0, 0.0};
      return f;
    };
    gap::heldout(runs, {}, fit);
    ASSERT_EQ(trained_on.size(), std::min<std::size_t>(n, 6)) << n << " runs";
    std::vector<int> held(n, 0);
    for (const auto& ids : trained_on) {
      // Each fold leaves out one block of consecutive runs and trains on all the others.
      std::vector<std::size_t> out;
      for (std::size_t i = 0; i < n; ++i)
        if (std::find(ids.begin(), ids.end(), i) == ids.end()) out.push_back(i);
      ASSERT_FALSE(out.empty());
      EXPECT_EQ(out.back() - out.front() + 1, out.size()) << n << " runs";
      for (std::size_t i : out) ++held[i];
    }
    for (std::size_t i = 0; i < n; ++i) EXPECT_EQ(held[i], 1) << "run " << i << " of " << n;
  }
}

TEST(TwoRuns, EachRunIsHeldOutInBlocksBesideTheOtherRun) {
  // Two runs of 7 points: each fold fits both runs with one block of one run masked out, and the
  // blocks cover every point of both runs once.
  std::vector<gap::Run> runs(2);
  for (std::size_t k = 0; k < 2; ++k) {
    runs[k].name = fmt::format("{}", k);
    for (int i = 0; i < 7; ++i) {
      runs[k].t_s.push_back(0.1 * i);
      runs[k].v_ref_mps.push_back(1.0);
      runs[k].slip.push_back(0.5);
      runs[k].force_n.push_back(static_cast<double>(k));
    }
  }
  std::vector<std::vector<int>> held(2, std::vector<int>(7, 0));
  std::size_t folds = 0;
  const gap::Fitter fit = [&](const std::vector<const gap::Run*>& train,
                              const std::vector<gap::Effect>&) {
    ++folds;
    EXPECT_EQ(train.size(), 2u);
    std::size_t masked_runs = 0;
    for (const auto* r : train) {
      if (r->fit_mask.empty()) continue;
      ++masked_runs;
      const auto k = static_cast<std::size_t>(std::stoul(r->name));
      std::vector<std::size_t> out;
      for (std::size_t i = 0; i < r->fit_mask.size(); ++i)
        if (!r->fitted_at(i)) out.push_back(i);
      EXPECT_FALSE(out.empty());
      if (out.empty()) continue;
      EXPECT_EQ(out.back() - out.front() + 1, out.size());  // one block of consecutive points
      EXPECT_EQ(r->fitted_points(), 7 - out.size());
      for (std::size_t i : out) ++held[k][i];
    }
    EXPECT_EQ(masked_runs, 1u);
    gap::Fit f;
    f.params = {1.0, 1.0, 0.0, 0.0};
    return f;
  };
  gap::heldout(runs, {}, fit);
  EXPECT_EQ(folds, 2 * gap::kTwoRunBlocks);
  for (std::size_t k = 0; k < 2; ++k)
    for (std::size_t i = 0; i < 7; ++i) EXPECT_EQ(held[k][i], 1) << "run " << k << " point " << i;
}

TEST(TwoRuns, ATimeOffsetIsPlacedOnBothRunsRamps) {
  // Seed 1102 of the every-station draw: a car's two runs at 2.1 km/h on two pedal ramps with a
  // 16 ms late pressure channel. One run alone cannot place the offset (on one ramp it is the
  // curve's own shift): held out a run at a time the offset lost 95 % against the baseline and
  // the set was `unexplained`; held out in blocks beside the other run it explains the gap.
  const auto set =
      sim2::draw_set(can::BenchKind::Roller, "time_offset", 0.01585, 1102, sim2::Stations::Every);
  ASSERT_EQ(set.runs.size(), 2u);
  const std::vector<gap::Run> runs = test::conditioned(set, false);
  const auto rep =
      gap::diagnose(runs, sim::pooled_start(runs), gap::calibrated_options(gap::Condition::Roller));
  ASSERT_FALSE(rep.verdict.empty());
  EXPECT_TRUE(rep.verdict.front() == "time_offset" || rep.verdict.front() == "relaxation_length")
      << rep.verdict.front();
  // Two runs' runaways meeting behind the offset are not read as a cap.
  EXPECT_EQ(std::count(rep.verdict.begin(), rep.verdict.end(), "cradle_cap"), 0);
  for (const auto& e : rep.effects)
    if (e.effect == gap::Effect::TimeOffset && e.round == 0) {
      EXPECT_GT(e.gain, 0.3);
    }
}

namespace {

/// A set of the every-station roller draw, conditioned, and the gates the referee calibrated for
/// that draw (gain 0.169, BIC 0.3504 per point, fit-quality factor 5.92).
struct EveryStationRoller {
  std::vector<gap::Run> runs;
  gap::Options gates = gap::calibrated_options(gap::Condition::Roller);
  EveryStationRoller(const std::string& effect, double magnitude, std::uint64_t seed)
      : runs(test::conditioned(
            sim2::draw_set(can::BenchKind::Roller, effect, magnitude, seed, sim2::Stations::Every),
            false)) {
    gates.gate_gain = 0.169;
    gates.noise_factor = 5.92;
    gates.bic_margin_per_point = 0.3504;
  }
  gap::Report diagnose(const gap::Options& o) const {
    return gap::diagnose(runs, sim::pooled_start(runs), o);
  }
};

}  // namespace

TEST(Gates, TheBicMarginIsPerPointFitted) {
  // Seed 1173 of the every-station draw: a car's two runs exported at 50 Hz, the pressure channel
  // 39 ms late. Its BIC drop (a few hundred points) stays under the 701 that a 2 000-point null
  // set's drop set as one margin for every set; per point, the same null asks ~0.35 of each.
  const EveryStationRoller set("time_offset", 0.03853, 1173);
  gap::Options absolute = set.gates;
  absolute.bic_margin = 700.8;
  absolute.bic_margin_per_point = 0.0;
  EXPECT_EQ(set.diagnose(absolute).verdict, std::vector<std::string>{"none"});
  const gap::Options& o = set.gates;
  EXPECT_NEAR(gap::bic_margin_for(o, 100), 35.04, 1e-9);
  EXPECT_EQ(gap::bic_margin_for(o, 10), 10.0);  // the floor
  const auto rep = set.diagnose(o);
  EXPECT_LT(gap::bic_margin_for(o, rep.before.points), 700.8);
  ASSERT_FALSE(rep.verdict.empty());
  EXPECT_TRUE(rep.verdict.front() == "time_offset" || rep.verdict.front() == "relaxation_length")
      << rep.verdict.front();
}

TEST(Gates, TwoLawsBitingAlikeNameNoEffect) {
  // Seed 500003 of the every-station draw: a truck's brush-model tyre (not a Magic Formula), five
  // runs at 100 Hz. A slip offset of -0.001 and a brake threshold take 28 % and 26 % of the
  // held-out gap alike, both at its foot; under the every-station gates no gap above the
  // fit-quality factor is left, and the offset was named.
  const EveryStationRoller set("misspecified", 0.0, 500003);
  const gap::Options& o = set.gates;
  const auto rep = set.diagnose(o);
  EXPECT_EQ(rep.verdict, std::vector<std::string>{"none"});
  EXPECT_TRUE(std::any_of(rep.notes.begin(), rep.notes.end(), [](const std::string& n) {
    return n.find("as much or more") != std::string::npos;
  }));
  // The rule itself: alike and small, over a gap that carries as much structure as noise.
  EXPECT_TRUE(gap::nibbled_alike(0.285, 0.260, 1.87, 1.0, o));
  EXPECT_FALSE(gap::nibbled_alike(0.285, 0.200, 1.87, 1.0, o));  // one stands out
  EXPECT_TRUE(gap::nibbled_alike(0.243, 0.347, 3.2, 1.0, o));    // the rival bit more
  EXPECT_FALSE(gap::nibbled_alike(0.45, 0.44, 1.87, 1.0, o));    // a large bite
  EXPECT_FALSE(gap::nibbled_alike(0.15, 0.14, 1.3, 1.0, o));     // the floor's own scatter
  EXPECT_FALSE(gap::nibbled_alike(0.16, 0.16, 1.87, 1.0, o));    // the rival under the gate
}
