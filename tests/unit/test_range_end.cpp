// The selection's rule held to the model as finally fitted (gates.cpp named_at_range_end): a
// named effect whose parameter the final fit puts at the end of its physical range is no
// physical account, and nothing is named. A body pitching undamped is at its lag's end (the
// selection's candidate rule, undamped_pitch).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <vector>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"
#include "sim/referee.hpp"
#include "tests/unit/referee_pair_test_util.hpp"

using namespace brakefit;

namespace {

/// A fit of B, C, D, E and load transfer (q, stiffness ratio, pitch lag, pitch mode).
gap::Fit load_transfer_fit(double kx_load_ratio) {
  gap::Fit f;
  f.params = {10.0, 1.6, 4000.0, 0.2, 0.03, kx_load_ratio, 0.1, 0.0};
  return f;
}

}  // namespace

TEST(RangeEnd, AStiffnessRatioAtItsEndIsNoPhysicalAccount) {
  const std::vector<gap::Effect> model{gap::Effect::LoadTransfer};
  const auto note = gap::named_at_range_end(model, load_transfer_fit(3.0));
  ASSERT_TRUE(note.has_value());
  EXPECT_NE(note->find("kx_load_ratio"), std::string::npos) << *note;
  EXPECT_NE(note->find("load_transfer"), std::string::npos) << *note;
  EXPECT_FALSE(gap::named_at_range_end(model, load_transfer_fit(1.25)).has_value());
  // The lower end of the ratio is an end too (0: the stiffness does not follow the load).
  EXPECT_TRUE(gap::named_at_range_end(model, load_transfer_fit(0.0)).has_value());
  // A pitch lag of 0 is a load that follows the deceleration at once: physical, not an end.
  gap::Fit at_once = load_transfer_fit(1.25);
  at_once.params[6] = 0.0;
  EXPECT_FALSE(gap::named_at_range_end(model, at_once).has_value());
}

TEST(RangeEnd, ABodyPitchingUndampedIsAtTheEndOfItsLag) {
  // The load through a body's pitch mode at 0.76 Hz (m = 1 / (2 pi 0.76)^2 s^2).
  const std::vector<gap::Effect> model{gap::Effect::LoadTransfer};
  const double mode_s2 = 1.0 / std::pow(2.0 * std::numbers::pi * 0.76, 2);
  gap::Fit f = load_transfer_fit(1.25);
  f.params[7] = mode_s2;
  f.params[6] = 0.0;  // damping 0: no vehicle's body swings so
  EXPECT_EQ(gap::undamped_pitch(model, gap::Effect::LoadTransfer, f), std::size_t{2});
  f.params[6] = 2.0 * 0.04 * std::sqrt(mode_s2);  // 4 % of critical
  EXPECT_EQ(gap::undamped_pitch(model, gap::Effect::LoadTransfer, f), std::size_t{2});
  f.params[6] = 2.0 * 0.3 * std::sqrt(mode_s2);  // a car's damper: 30 % of critical
  EXPECT_FALSE(gap::undamped_pitch(model, gap::Effect::LoadTransfer, f).has_value());
  // A mode faster than a body's (20 Hz) without damping follows the deceleration at once.
  f.params[7] = 1.0 / std::pow(2.0 * std::numbers::pi * 20.0, 2);
  f.params[6] = 0.0;
  EXPECT_FALSE(gap::undamped_pitch(model, gap::Effect::LoadTransfer, f).has_value());
  // Another effect's parameters are no pitch.
  EXPECT_FALSE(gap::undamped_pitch(model, gap::Effect::WheelInertia, f).has_value());
}

TEST(RangeEnd, NuisanceTermsAreNotNamedEffects) {
  // The reference's slip bias on its bound is the quantisation's, not an effect's law.
  const std::vector<gap::Effect> model{gap::Effect::ReferenceBias};
  gap::Fit f;
  f.params = {10.0, 1.6, 4000.0, 0.2, 0.01};
  EXPECT_FALSE(gap::named_at_range_end(model, f).has_value());
}

TEST(RangeEnd, ABurckhardtTyreOnTheGroundIsNotNamedLoadTransfer) {
  // Generator A's misspecified ground set 2 (a Burckhardt curve, no effect): a threshold, then
  // load transfer with its stiffness ratio at 2.9 passed the selection; refitted once the
  // encoders' ripple was estimated against them, the ratio sat at its end (3).
  sim::Injection inj;
  inj.effect = "misspecified";
  inj.condition = gap::Condition::Ground;
  inj.generator = sim::Generator::A;
  const auto t = sim::run_trial(inj, sim::misspecified_seed(2),
                                gap::calibrated_options(gap::Condition::Ground));
  ASSERT_FALSE(t.verdict.empty());
  EXPECT_TRUE(t.verdict.front() == "none" || t.verdict.front() == "unexplained") << test::why_of(t);
  EXPECT_EQ(std::find(t.verdict.begin(), t.verdict.end(), "load_transfer"), t.verdict.end());
}

TEST(RangeEnd, AFadingTyreIsNotALoadPitchingUndamped) {
  // Generator B's ground outside set 7 from every export: a fading tyre (1/(1 + 0.26 per m slid))
  // on two runs at 76-126 km/h, 200 Hz. Load transfer alone fitted it in-sample better than the
  // fade in its place, with the load swinging through a 0.76 Hz mode at damping 0.
  const test::EveryExport every;
  const auto t = sim::run_trial(sim::draw_outside(7, gap::Condition::Ground),
                                sim::outside_seed(7), test::every_export_ground_gates());
  ASSERT_FALSE(t.verdict.empty());
  EXPECT_EQ(std::find(t.verdict.begin(), t.verdict.end(), "load_transfer"), t.verdict.end())
      << test::why_of(t);
  EXPECT_TRUE(t.verdict.front() == "unexplained" || t.verdict.front() == "none")
      << test::why_of(t);
}
