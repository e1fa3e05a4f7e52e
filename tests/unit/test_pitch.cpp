// The body's pitch behind a ground run's load transfer: the diagnosis's law (a first-order lag or
// a damped pitch mode, core/gap/effects.cpp) and generator B's draw of it (issue 34).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "core/gap/internal.hpp"
#include "sim/referee.hpp"
#include "sim/second/generator.hpp"

using namespace brakefit;

namespace {

/// A run at 1 kHz whose deceleration steps from 0 to 1 m/s^2 at t = 0.1 s.
gap::Run step_run() {
  gap::Run r;
  for (int i = 0; i < 3000; ++i) {
    r.t_s.push_back(i * 1e-3);
    r.ref_decel_mps2.push_back(i >= 100 ? 1.0 : 0.0);
  }
  return r;
}

}  // namespace

TEST(Pitch, AModeOvershootsAStepAsASecondOrderSystemDoes) {
  // m x'' + lag x' + x = a with m = 1 / w^2 and lag = 2 zeta / w: a 1.25 Hz mode at damping 0.4
  // peaks exp(-pi zeta / sqrt(1 - zeta^2)) above the step, half a damped period after it.
  const double hz = 1.25, zeta = 0.4, w = 2 * M_PI * hz;
  const gap::Run r = step_run();
  const auto x = gap::pitch_lagged_decel(r, 2 * zeta / w, 1 / (w * w));
  const auto peak = std::max_element(x.begin(), x.end());
  const double overshoot = std::exp(-M_PI * zeta / std::sqrt(1 - zeta * zeta));
  EXPECT_NEAR(*peak - 1.0, overshoot, 0.03 * overshoot);  // backward Euler damps a little
  const double t_peak = r.t_s[static_cast<std::size_t>(peak - x.begin())] - 0.1;
  EXPECT_NEAR(t_peak, M_PI / (w * std::sqrt(1 - zeta * zeta)), 0.01);
  EXPECT_NEAR(x.back(), 1.0, 0.01);  // it settles on the step: unit gain
  // Without a mode it is the first-order lag: no overshoot, 63 % of the step one lag after it.
  const auto lag = gap::pitch_lagged_decel(r, 0.1, 0.0);
  EXPECT_LE(*std::max_element(lag.begin(), lag.end()), 1.0);
  EXPECT_NEAR(lag[200], 1 - std::exp(-1.0), 0.01);
  // Neither: the deceleration itself.
  EXPECT_EQ(gap::pitch_lagged_decel(r, 0.0, 0.0), r.ref_decel_mps2);
}

TEST(Pitch, ThePitchStartsFromTheRunsFirstDecelerationsNotItsFirstSample) {
  // A run starts from a wheel rolling free: the body rests in pitch. The first sample's derivative
  // is taken at the smoothed speed's edge and can be far off (10 m/s^2 on a 70 km/h run of
  // generator C); a lag started there carried it as load for a lag's time or two.
  gap::Run r = step_run();
  r.ref_decel_mps2[0] = 10.0;
  for (const double mode_s2 : {0.0, 0.0162}) {
    const auto x = gap::pitch_lagged_decel(r, 0.1, mode_s2);
    for (std::size_t i = 0; i < 100; ++i) EXPECT_NEAR(x[i], 0.0, 0.1) << "sample " << i;
    EXPECT_NEAR(x.back(), 1.0, 0.01);
  }
  // Without a lag the load follows the deceleration as read, the first sample included.
  EXPECT_EQ(gap::pitch_lagged_decel(r, 0.0, 0.0), r.ref_decel_mps2);
  // A run that starts already decelerating (its first 40 ms at 2 m/s^2) starts there.
  gap::Run on = step_run();
  for (double& d : on.ref_decel_mps2) d += 2.0;
  EXPECT_NEAR(gap::pitch_lagged_decel(on, 0.1, 0.0)[1], 2.0, 1e-9);
}

TEST(Pitch, GeneratorBDrawsALagOrAModeForEachVehicle) {
  // Half the vehicles let the load follow 0-0.2 s behind the deceleration, half through a mode of
  // 1-1.5 Hz at damping 0.3-0.7; the station says which. The draw has its own stream: the rest of
  // a seed's set (tyre, load, export) does not move with it.
  int lags = 0, modes = 0;
  for (std::uint64_t seed = 1; seed <= 40; ++seed) {
    const auto set = sim2::draw_set(can::BenchKind::Ground, "load_transfer", 0.0, seed);
    const auto& r = set.runs.front();
    if (r.pitch_hz > 0) {
      ++modes;
      EXPECT_GE(r.pitch_hz, 1.0);
      EXPECT_LE(r.pitch_hz, 1.5);
      EXPECT_GE(r.pitch_damping, 0.3);
      EXPECT_LE(r.pitch_damping, 0.7);
      EXPECT_NE(set.station.find("pitch mode"), std::string::npos) << set.station;
    } else {
      ++lags;
      EXPECT_GE(r.pitch_lag_s, 0.0);
      EXPECT_LE(r.pitch_lag_s, 0.2);
      EXPECT_NE(set.station.find("pitch lag"), std::string::npos) << set.station;
    }
    for (const auto& run : set.runs) EXPECT_EQ(run.pitch_hz, r.pitch_hz);  // one vehicle
  }
  EXPECT_GE(lags, 10);
  EXPECT_GE(modes, 10);
}

TEST(Pitch, ALoadThatFollowsAPitchModeIsNamedWithItsMagnitudeAndMode) {
  // A load that follows the deceleration through a 1.25 Hz mode overshoots it by a fifth: read
  // through a first-order lag, load transfer's magnitude came out 50-84 % high on such sets
  // (seed 1: 79 N of a 419 N gap left). With the mode in the law the magnitude is within 15 % and
  // the mode read back.
  for (std::uint64_t seed : {1u, 5u, 8u}) {
    sim2::SetDraw set = sim2::draw_set(can::BenchKind::Ground, "load_transfer", 0.0, seed);
    std::vector<gap::Run> runs;
    for (auto& run : set.runs) {
      run.pitch_hz = 1.25;
      run.pitch_damping = 0.45;
      sim::append_event_csv_runs(runs, sim2::simulate_event_csv(run), "b");
    }
    const gap::Report rep = gap::diagnose(runs, sim::pooled_start(runs),
                                          gap::calibrated_options(gap::Condition::Ground));
    ASSERT_FALSE(rep.verdict.empty());
    EXPECT_EQ(rep.verdict.front(), "load_transfer") << "seed " << seed;
    bool mode = false;
    for (const auto& e : rep.effects) {
      if (e.effect != gap::Effect::LoadTransfer || !e.accepted) continue;
      for (const auto& [name, v] : e.params) {
        if (name == "dfz_per_decel_s2_per_m") {
          EXPECT_NEAR(v, set.magnitude, 0.15 * set.magnitude) << "seed " << seed;
        }
        if (name == "pitch_mode_hz") {
          mode = true;
          EXPECT_NEAR(v, 1.25, 0.3) << "seed " << seed;
        }
      }
    }
    EXPECT_TRUE(mode) << "seed " << seed;
  }
}
