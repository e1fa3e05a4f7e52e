// The evidence only one effect leaves (issue 34): a brake threshold holds the wheel rolling free
// while the pressure rises to it; a steep foot of a curve that is not a Magic Formula does not. A
// slip offset reads as itself while the wheel rolls free; speed friction needs roller speeds apart.
#include <gtest/gtest.h>

#include <utility>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"

using namespace brakefit;

namespace {

/// A roller run from rest: the force ramps 0 -> 1200 N; below p0 (2 bar, 120 N) the slip stays
/// at its rest value (dead zone) or follows the force at the curve's initial stiffness.
gap::Run rise(bool dead_zone) {
  gap::Run r;
  r.bench = can::BenchKind::Roller;
  r.brake_gain_n_per_bar = 60.0;
  const double stiffness_n = 80'000.0, thr_n = 120.0;
  for (int i = 0; i <= 400; ++i) {
    const double f = 3.0 * i;
    r.t_s.push_back(0.001 * i);
    r.force_n.push_back(f);
    const double tyre_n = dead_zone ? std::max(0.0, f - thr_n) : f;
    r.slip.push_back(2e-4 + tyre_n / stiffness_n);
  }
  return r;
}

/// A candidate that passed the gates with its one parameter at `value`, and its fit: B C D of
/// 80 kN (the curve's initial stiffness) and the parameter.
std::pair<gap::EffectScore, gap::Fit> candidate(gap::Effect e, const char* name, double value) {
  gap::EffectScore s;
  s.effect = e;
  s.params = {{name, value}};
  s.gain = 0.3;
  gap::Fit f;
  f.params = {16.0, 1.6, 3125.0, 0.1, value};
  return {s, f};
}

}  // namespace

TEST(GapEvidence, ABrakeThresholdNeedsAWheelRollingFreeBelowIt) {
  const auto [s, f] = candidate(gap::Effect::BrakeThreshold, "p0_bar", 2.0);
  EXPECT_FALSE(gap::missing_evidence(s, f, {rise(true), rise(true)}).has_value());
  const auto missing = gap::missing_evidence(s, f, {rise(false), rise(false)});
  ASSERT_TRUE(missing.has_value());
  EXPECT_NE(missing->note.find("did not roll free below it"), std::string::npos);
  // A run that starts above the threshold shows no rise: nothing to hold against it.
  gap::Run late = rise(false);
  for (double& x : late.force_n) x += 200.0;
  EXPECT_FALSE(gap::missing_evidence(s, f, {late, late}).has_value());
}

TEST(GapEvidence, ASlipOffsetMustReadAsItselfWhileTheWheelRollsFree) {
  const auto [s, f] = candidate(gap::Effect::SlipOffset, "slip_offset_ratio", -6e-4);
  // A run whose samples at rest have this mean and standard deviation.
  auto at_rest = [](double mean, std::size_t points, double sd = 2e-4) {
    gap::Run r = rise(false);
    const auto n = static_cast<double>(points);
    r.rest_slip_sum = n * mean;
    r.rest_slip_sq_sum = n * (sd * sd + mean * mean);
    r.rest_slip_points = points;
    return r;
  };
  // The rest shows the offset: named. It shows none (a steep foot fitted as an offset): refused.
  EXPECT_FALSE(gap::missing_evidence(s, f, {at_rest(-5.8e-4, 100), at_rest(-6.1e-4, 100)}));
  const auto missing = gap::missing_evidence(s, f, {at_rest(1e-5, 100), at_rest(-2e-5, 100)});
  ASSERT_TRUE(missing.has_value());
  EXPECT_NE(missing->note.find("rolling free before the brake"), std::string::npos);
  // Too few samples at rest to say, or a rest whose noise covers the offset: not refused.
  EXPECT_FALSE(gap::missing_evidence(s, f, {at_rest(0, 4), at_rest(0, 4)}));
  const gap::Run noisy = at_rest(0, 20, 3e-3);
  EXPECT_FALSE(gap::missing_evidence(s, f, {noisy, noisy}));
}

TEST(GapEvidence, SpeedFrictionOnARollerNeedsRunsAtSpeedsApart) {
  const auto [s, f] = candidate(gap::Effect::SpeedFriction, "lambda_mu_v", 10.0);
  auto at_speed = [](double v_mps) {
    gap::Run r = rise(false);
    r.v_ref_mps.assign(r.t_s.size(), v_mps);
    return r;
  };
  const auto missing = gap::missing_evidence(s, f, {at_speed(1.39), at_speed(1.40)});
  ASSERT_TRUE(missing.has_value());
  EXPECT_NE(missing->note.find("one speed"), std::string::npos);
  EXPECT_FALSE(gap::missing_evidence(s, f, {at_speed(0.6), at_speed(1.6)}));
  // On the ground a stop spans its speeds: not this check's to refuse.
  gap::Run ground = at_speed(11.0);
  ground.bench = can::BenchKind::Ground;
  EXPECT_FALSE(gap::missing_evidence(s, f, {ground, ground}));
}
