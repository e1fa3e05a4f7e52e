// The runs' reference biases on a roller held at one quantised speed, levelled at zero force: a
// relaxation levels them at its own length, else its lag's signature goes into the biases.
#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/gap/channels.hpp"
#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"
#include "sim/referee.hpp"
#include "sim/second/generator.hpp"
#include "tests/unit/b_runs_test_util.hpp"

using namespace brakefit;

// The change read on the grid of lengths is interpolated between its lengths, held past its last
// and nothing at none or where the run was not levelled.
TEST(GapLevelling, ARelaxationsChangeIsInterpolatedOnTheGrid) {
  gap::Run r;
  EXPECT_EQ(gap::relaxation_level_change(r, 0.2), 0.0);  // not levelled
  const auto& grid = gap::kLevellingSigmaM;
  for (std::size_t k = 0; k < grid.size(); ++k)
    r.ref_bias_by_sigma.push_back(1e-4 * static_cast<double>(k));
  EXPECT_EQ(gap::relaxation_level_change(r, 0.0), 0.0);
  EXPECT_NEAR(gap::relaxation_level_change(r, 0.5 * (grid[2] + grid[3])), 2.5e-4, 1e-12);
  EXPECT_NEAR(gap::relaxation_level_change(r, grid[3]), 3e-4, 1e-12);
  const double last = 1e-4 * static_cast<double>(grid.size() - 1);
  EXPECT_NEAR(gap::relaxation_level_change(r, 2 * grid.back()), last, 1e-12);  // held past it
  r.ref_bias_by_sigma.pop_back();
  EXPECT_EQ(gap::relaxation_level_change(r, 0.1), 0.0);  // not the grid's size: not used
}

// Generator B's cars on the roller, a relaxation alone, the encoders' steps kept (the rest of the
// tester ideal). Levelled at none, the biases took part of the lag and these lengths were read
// 15-55 % short; levelled at the length fitted they are read within 5 %.
TEST(GapLevelling, ARelaxationOnAQuantisedRollerLevelsAtItsOwnLength) {
  struct Case {
    std::uint64_t seed;
    double sigma_m;
  };
  for (const Case c : {Case{2, 0.1}, Case{8, 0.1}, Case{11, 0.1}, Case{8, 0.4}}) {
    auto set = sim2::draw_set(can::BenchKind::Roller, {{"relaxation_length", c.sigma_m}}, c.seed);
    const double filter_s = set.runs.front().tester.pressure_filter_s;
    std::vector<gap::Run> runs = test::ideal_runs(set, filter_s, true);
    ASSERT_GE(runs.size(), 2u) << set.station;
    ASSERT_GT(runs.front().ref_bias_bound, 0.0) << set.station << ": no bias to level";
    gap::level_reference_biases(runs);
    const std::vector<gap::Effect> model{gap::Effect::RelaxationLength};
    const gap::Fit own = gap::fit_runs(gap::pointers(runs), model, sim::pooled_start(runs));
    EXPECT_NEAR(own.params[4], set.magnitude, 0.05 * set.magnitude)
        << "seed " << c.seed << ", " << set.station;
    for (auto& r : runs) r.ref_bias_by_sigma.clear();  // levelled at none
    const gap::Fit at_none = gap::fit_runs(gap::pointers(runs), model, sim::pooled_start(runs));
    EXPECT_GT(std::abs(at_none.params[4] - set.magnitude), 0.1 * set.magnitude)
        << "seed " << c.seed << ": the levelling at none no longer takes the lag";
  }
}
