// A cap read from how the runs end is weighed again beside the effects named with it: where the
// curve fitted with them to the whole runs peaks at the runaway, the tyre's own sharp peak and a
// cap cannot be told apart and no cap is named; a cap below the peak stays.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <string>

#include "core/gap/gap.hpp"
#include "sim/referee.hpp"
#include "tests/unit/referee_pair_test_util.hpp"

namespace brakefit {
namespace {

TEST(CapBesideNamed, ATrucksThresholdIsNotGivenACap) {
  // Every export's roller trial 172: a truck's two runs at 2.4 km/h, 250 Hz, a 0.21 bar
  // threshold. Its runs ran away at one force (spread 0.6 %) still rising; the curve fitted
  // without the threshold peaks past that, with it at the runaway.
  const auto t = test::every_export_roller_trial(172);
  ASSERT_EQ(t.truth.effect, "brake_threshold");
  EXPECT_FALSE(test::names(t, "cradle_cap")) << test::why_of(t);
  ASSERT_FALSE(t.verdict.empty());
  EXPECT_EQ(t.verdict.front(), "brake_threshold") << test::why_of(t);
  EXPECT_NEAR(t.estimate, t.truth.magnitude, 0.15 * t.truth.magnitude);
}

TEST(CapBesideNamed, ATrucksSlipOffsetAtOneHundredHertzIsNotGivenACap) {
  // Trial 175: a truck's three runs at 2.8 km/h, 100 Hz, its wheel's radius 0.54 % off, whose
  // rest at 100 Hz is within its uncertainty (the cap's own check from the rest cannot use it).
  const auto t = test::every_export_roller_trial(175);
  ASSERT_EQ(t.truth.effect, "slip_offset");
  EXPECT_FALSE(test::names(t, "cradle_cap")) << test::why_of(t);
  ASSERT_FALSE(t.verdict.empty());
  EXPECT_EQ(t.verdict.front(), "slip_offset") << test::why_of(t);
}

TEST(CapBesideNamed, ACradlesCapBesideAThresholdStays) {
  // Generator A's first roller pair drawing a cradle cap with a brake threshold: the cap is below
  // the tyre's peak, and the curve fitted with the threshold to the whole runs rises past it.
  Rng rng(sim::pair_draw_seed(1, gap::Condition::Roller));
  int index = -1;
  for (int i = 0; i < 200 && index < 0; ++i) {
    const sim::Injection inj = sim::draw_pair(rng, gap::Condition::Roller, sim::Generator::A);
    const bool cap = inj.effect == "cradle_cap" || inj.effect2 == "cradle_cap";
    const bool threshold = inj.effect == "brake_threshold" || inj.effect2 == "brake_threshold";
    if (cap && threshold) index = i;
  }
  ASSERT_GE(index, 0);
  const auto p = test::referee_pair(gap::Condition::Roller, sim::Generator::A, index);
  EXPECT_TRUE(test::names(p.res, "cradle_cap")) << p.why;
  EXPECT_TRUE(test::names(p.res, "brake_threshold")) << p.why;
}

}  // namespace
}  // namespace brakefit
