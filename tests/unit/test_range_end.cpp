// The selection's rule held to the model as finally fitted (gates.cpp named_at_range_end): a
// named effect whose parameter the final fit puts at the end of its physical range is no
// physical account, and nothing is named.
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
