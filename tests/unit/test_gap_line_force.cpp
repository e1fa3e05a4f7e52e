// The line's force at a run's start behind a declared pressure filter: the ramp the line had made
// before the channel showed it, the force a relaxing contact's transient slip starts from.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/gap/channels.hpp"
#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"
#include "sim/referee.hpp"
#include "sim/second/generator.hpp"
#include "tests/unit/b_runs_test_util.hpp"

using namespace brakefit;

TEST(GapLineForce, AFilteredRampsOnsetBeforeTheRunGivesTheLinesForceAtItsStart) {
  // A line ramping at 20 kN/s from 4 ms before the run, seen through a 12 ms filter and sampled at
  // 1 kHz: at the run's start the channel reads 0.6 N, the line 80 N.
  const double tau_s = 0.012, rate = 20'000, onset_s = -0.004;
  std::vector<double> t_s, f_n;
  for (int i = 0; i < 120; ++i) {
    const double t = 1e-3 * i, u = t - onset_s;
    t_s.push_back(t);
    f_n.push_back(rate * (u - tau_s * (1 - std::exp(-u / tau_s))));
  }
  EXPECT_NEAR(gap::line_force_at_start(t_s, f_n, tau_s), 80.0, 4.0);
  // Without a declared filter the channel is the line: a line through its first 20 ms.
  const double plain = gap::line_force_at_start(t_s, f_n, 0.0);
  EXPECT_DOUBLE_EQ(plain, gap::start_line(t_s, f_n, gap::kStartForceWindowS).at_start);
  // A ramp the channel starts on after the run's start is at rest there.
  for (double& f : f_n) f = 0;
  for (int i = 10; i < 120; ++i) {
    const double u = 1e-3 * (i - 10);
    f_n[i] = rate * (u - tau_s * (1 - std::exp(-u / tau_s)));
  }
  EXPECT_NEAR(gap::line_force_at_start(t_s, f_n, tau_s), 0.0, 4.0);
}

// A truck tyre's 0.357 m relaxation at 43-78 km/h, behind a 12 ms pressure filter (the encoders
// and the pressure otherwise ideal): the contact relaxes from the line's force at the run's start.
// From the channel's (a few newtons where the line has tens) the contact started late and the
// length was read 0.29.
TEST(GapLineForce, ARelaxingContactStartsFromTheLinesForceBehindADeclaredFilter) {
  auto set = sim2::draw_set(can::BenchKind::Ground, {{"relaxation_length", 0.357}}, 801039,
                            sim2::Stations::Every);
  const std::vector<gap::Run> runs = test::ideal_runs(set, 0.012);
  ASSERT_FALSE(runs.empty()) << set.station;
  const std::vector<gap::Effect> model{gap::Effect::RelaxationLength};
  const gap::Fit f = gap::fit_runs(gap::pointers(runs), model, sim::pooled_start(runs));
  EXPECT_NEAR(f.params[4], set.magnitude, 0.05 * set.magnitude) << set.station;
}
