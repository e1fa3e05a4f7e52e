// Each named effect against a friction fading with the energy slid (core/gap/fade_rival.cpp):
// the fade's law, and the check that names nothing where the fade explains the runs better.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"
#include "sim/referee.hpp"
#include "tests/unit/referee_pair_test_util.hpp"

using namespace brakefit;

namespace {

/// A run at a steady 20 m/s and 5 % slip under a force rising 1 kN per second.
gap::Run steady_run() {
  gap::Run r;
  for (int i = 0; i <= 100; ++i) {
    const double t_s = 0.01 * i;
    r.t_s.push_back(t_s);
    r.slip.push_back(0.05);
    r.v_ref_mps.push_back(20.0);
    r.force_n.push_back(1000.0 * t_s);
  }
  const std::size_t n = r.t_s.size();
  r.wheel_accel_mps2.assign(n, 0.0);
  r.ref_decel_mps2.assign(n, 0.0);
  r.pressure_rate_bar_per_s.assign(n, 0.0);
  r.wheel_radius_m = 0.3;
  return r;
}

bool fade_note(const sim::TrialResult& t) {
  return std::any_of(t.notes.begin(), t.notes.end(), [](const std::string& s) {
    return s.find("fading with the energy") != std::string::npos;
  });
}

}  // namespace

TEST(FadeRival, TheEnergySlidIsTheSlidingPowerIntegrated) {
  const gap::Run r = steady_run();
  const auto e_kj = gap::slid_energy_kj(r);
  ASSERT_EQ(e_kj.size(), r.t_s.size());
  // P = F x slip x V = 1000 t x 0.05 x 20 W: E = 500 t^2 J.
  for (std::size_t i = 0; i < r.t_s.size(); i += 10)
    EXPECT_NEAR(e_kj[i], 0.5 * r.t_s[i] * r.t_s[i], 1e-9) << "sample " << i;
}

TEST(FadeRival, TheFadeScalesThePeakByOneOverOnePlusKE) {
  const gap::Run r = steady_run();
  const std::vector<double> plain_p{10.0, 1.6, 3000.0, 0.0};
  std::vector<double> faded_p = plain_p;
  faded_p.push_back(0.4);  // per kJ
  const auto plain = gap::predict(r, plain_p, {});
  const auto faded = gap::predict(r, faded_p, {gap::Effect::FrictionFade});
  const auto e_kj = gap::slid_energy_kj(r);
  for (std::size_t i = 0; i < r.t_s.size(); i += 10)
    EXPECT_NEAR(faded[i], plain[i] / (1 + 0.4 * e_kj[i]), 1e-6) << "sample " << i;
  EXPECT_LT(faded.back(), 0.85 * plain.back());  // E = 0.5 kJ at the end: a sixth off
}

TEST(FadeRival, AFadeOnTheGroundIsNotNamedSpeedFriction) {
  // Generator B's ground runs at 30, 50 and 70 km/h: the faster runs slide more per unit of slip
  // and fade more, as a friction falling with the sliding speed does. Speed friction is named
  // here with load transfer (a pair, judged on every run at once); the fade fitted in speed
  // friction's place leaves a third of what it leaves.
  const gap::Options o = gap::calibrated_options(gap::Condition::Ground);
  const sim::Injection inj{"friction_fade", 1.0, gap::Condition::Ground, sim::Generator::B};
  const auto t = sim::run_trial(inj, 2, o);
  EXPECT_FALSE(test::names(t, "speed_friction"));
  ASSERT_FALSE(t.verdict.empty());
  EXPECT_EQ(t.verdict.front(), "unexplained");
  EXPECT_TRUE(fade_note(t));
  // A friction that falls with the sliding speed is still speed friction's.
  const sim::Injection sf{"speed_friction", 1.0, gap::Condition::Ground, sim::Generator::B};
  const auto s = sim::run_trial(sf, 5, o);
  ASSERT_FALSE(s.verdict.empty());
  EXPECT_EQ(s.verdict.front(), "speed_friction");
  EXPECT_FALSE(fade_note(s));
}

TEST(FadeRival, AFadingRollerTyreIsNotNamedWheelInertia) {
  // Generator B's outside set 29 from every export: a car's five runs at 2.4 km/h, 200 Hz. At one
  // speed the slow ramp slides longest and fades most; a wheel's inertia takes part of that (it
  // passes the gates), the fade in its place leaves under half of what it leaves.
  const test::EveryExport every;
  gap::Options gates;  // the referee's gates for every export's roller sets
  gates.gate_gain = 0.169;
  gates.bic_margin_per_point = 0.3504;
  gates.noise_factor = 1.56;
  const auto t =
      sim::run_trial(sim::draw_outside(29, gap::Condition::Roller), sim::outside_seed(29), gates);
  EXPECT_FALSE(test::names(t, "wheel_inertia"));
  ASSERT_FALSE(t.verdict.empty());
  EXPECT_EQ(t.verdict.front(), "unexplained") << ::testing::PrintToString(t.verdict);
  EXPECT_TRUE(fade_note(t));
}

TEST(FadeRival, AFadeNamedWithLoadTransferIsWeighedOnEveryRunAlike) {
  // Generator B's ground outside set 13: a fading tyre (1/(1 + 0.46 per m slid)) on three runs
  // at 30-70 km/h. Load transfer with speed friction passes as a pair judged in-sample; the fade
  // in speed friction's place, on the same points with one parameter as well, leaves less.
  const gap::Options o = gap::calibrated_options(gap::Condition::Ground);
  const auto t =
      sim::run_trial(sim::draw_outside(13, gap::Condition::Ground), sim::outside_seed(13), o);
  EXPECT_FALSE(test::names(t, "speed_friction")) << test::why_of(t);
  EXPECT_FALSE(test::names(t, "load_transfer")) << test::why_of(t);
  ASSERT_FALSE(t.verdict.empty());
  EXPECT_EQ(t.verdict.front(), "unexplained");
  EXPECT_TRUE(fade_note(t));
}

TEST(FadeRival, AModelThatDoesBetterHeldOutKeepsTheHeldOutMargin) {
  // The referee's ground trial 22 (generator B, seed 1): load transfer (0.049 per m/s^2, the
  // body's 1.34 Hz pitch mode), named with a wheel inertia as a pair judged held out. In-sample
  // a 3 % fade in the inertia's place fits 5 % closer: no better account by the margin the pair
  // was chosen with, and load transfer stays named.
  Rng rng(1 + 100 * static_cast<std::uint64_t>(gap::Condition::Ground));
  sim::Injection inj;
  for (int t = 0; t <= 22; ++t)
    inj = sim::draw_injection(rng, 0.35, gap::Condition::Ground, sim::Generator::B);
  ASSERT_EQ(inj.effect, "load_transfer");
  gap::Options gates = gap::calibrated_options(gap::Condition::Ground);
  gates.gate_gain = 0.123;  // the referee's gates for B's ground sets
  gates.bic_margin_per_point = 0.0950;
  const auto t = sim::run_trial(
      inj, 1000 + 22 + 100'000 * static_cast<std::uint64_t>(gap::Condition::Ground), gates);
  ASSERT_FALSE(t.verdict.empty());
  EXPECT_EQ(t.verdict.front(), "load_transfer") << test::why_of(t);
  EXPECT_FALSE(fade_note(t)) << test::why_of(t);
}

TEST(FadeRival, LoadTransferIsWeighedAgainstTheFadeInItsPlace) {
  // Generator B's ground outside set 29 from every export: a fading tyre (1/(1 + 0.43 per m slid))
  // on five runs at 45-112 km/h, 200 Hz. Speed friction with load transfer passes held out; the
  // fade in load transfer's place, with one parameter against its four, leaves less on the same
  // points.
  const test::EveryExport every;
  const auto t = sim::run_trial(sim::draw_outside(29, gap::Condition::Ground),
                                sim::outside_seed(29), test::every_export_ground_gates());
  EXPECT_FALSE(test::names(t, "load_transfer")) << test::why_of(t);
  EXPECT_FALSE(test::names(t, "speed_friction")) << test::why_of(t);
  ASSERT_FALSE(t.verdict.empty());
  EXPECT_EQ(t.verdict.front(), "unexplained");
  EXPECT_TRUE(fade_note(t)) << test::why_of(t);
}
