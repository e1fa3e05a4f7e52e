// Two effects injected into one set: the referee's draws and scoring of a pair, and forward
// selection naming both (bench/gap_referee --pairs runs them by the hundred).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>
#include <string>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"
#include "sim/referee.hpp"
#include "sim/second/generator.hpp"
#include "tests/unit/b_runs_test_util.hpp"
#include "tests/unit/referee_pair_test_util.hpp"

using namespace brakefit;
using brakefit::test::referee_pair;

TEST(GapPairs, DrawsTwoDifferentEffectsAndNeverLagWithDelay) {
  for (auto [c, g] : {std::pair{gap::Condition::Roller, sim::Generator::A},
                      std::pair{gap::Condition::Ground, sim::Generator::A},
                      std::pair{gap::Condition::Roller, sim::Generator::B},
                      std::pair{gap::Condition::Ground, sim::Generator::B}}) {
    Rng rng(9);
    std::set<std::string> seen;
    for (int i = 0; i < 300; ++i) {
      const auto inj = sim::draw_pair(rng, c, g);
      ASSERT_TRUE(inj.pair());
      EXPECT_NE(inj.effect, inj.effect2);
      EXPECT_FALSE(std::set<std::string>({inj.effect, inj.effect2}) ==
                   std::set<std::string>({"relaxation_length", "time_offset"}));
      EXPECT_NE(inj.magnitude, 0.0);
      EXPECT_NE(inj.magnitude2, 0.0);
      seen.insert(inj.effect);
      seen.insert(inj.effect2);
    }
    // Every effect of the condition takes part in some pair.
    EXPECT_EQ(seen.size(), sim::referee_effects(c, g).size()) << gap::to_string(c);
  }
}

TEST(GapPairs, GeneratorCsPairsShareOneMagnitudeInsideBothRanges) {
  // Generator C's script gives a set one magnitude: its pairs are two effects whose ranges
  // overlap, both at one value inside both ranges; its roller has no two such effects.
  Rng rng(5);
  std::set<std::set<std::string>> seen;
  for (int i = 0; i < 300; ++i) {
    const auto inj = sim::draw_pair(rng, gap::Condition::Ground, sim::Generator::C);
    ASSERT_TRUE(inj.pair());
    EXPECT_NE(inj.effect, inj.effect2);
    EXPECT_EQ(inj.magnitude, inj.magnitude2);
    for (const auto& e : {inj.effect, inj.effect2}) {
      const auto [lo, hi] = sim::effect_range(gap::Condition::Ground, sim::Generator::C, e);
      EXPECT_GE(inj.magnitude, lo) << e;
      EXPECT_LE(inj.magnitude, hi) << e;
    }
    seen.insert({inj.effect, inj.effect2});
  }
  // Thresholds, inertias and speed frictions share 1.0-1.5; relaxation and load transfer
  // 0.17-0.28 (generator C's README).
  EXPECT_EQ(seen, (std::set<std::set<std::string>>{{"brake_threshold", "wheel_inertia"},
                                                   {"brake_threshold", "speed_friction"},
                                                   {"speed_friction", "wheel_inertia"},
                                                   {"load_transfer", "relaxation_length"}}));
  EXPECT_TRUE(sim::draws_pairs(gap::Condition::Ground, sim::Generator::C));
  EXPECT_FALSE(sim::draws_pairs(gap::Condition::Roller, sim::Generator::C));
  EXPECT_TRUE(sim::draws_pairs(gap::Condition::Roller, sim::Generator::B));
  EXPECT_THROW(sim::draw_pair(rng, gap::Condition::Roller, sim::Generator::C), InputError);
}

TEST(GapPairs, APairIsCorrectOnlyWhenBothAreNamed) {
  sim::TrialResult t;
  t.truth.effect = "brake_threshold";
  t.truth.effect2 = "slip_offset";
  t.verdict = {"brake_threshold"};
  EXPECT_FALSE(t.correct());
  EXPECT_FALSE(t.exact());
  t.verdict = {"slip_offset", "brake_threshold"};
  EXPECT_TRUE(t.correct());
  EXPECT_TRUE(t.exact());
  t.verdict = {"slip_offset", "wheel_inertia", "brake_threshold"};
  EXPECT_TRUE(t.correct());  // both named, with a third
  EXPECT_FALSE(t.exact());
  // One of them said as another it cannot be told from: named, honestly.
  t.truth.effect2 = "time_offset";
  t.verdict = {"brake_threshold", "relaxation_length"};
  EXPECT_FALSE(t.correct());
  t.notes = {
      "the data cannot separate relaxation_length from time_offset (held-out gains 0.4 "
      "and 0.4)"};
  EXPECT_TRUE(t.correct());
  // One name cannot stand for both, even where a note ties it to the other.
  t.verdict = {"relaxation_length", "unexplained"};
  t.truth.effect = "load_transfer";
  t.truth.effect2 = "relaxation_length";
  t.notes = {
      "the data cannot separate relaxation_length from load_transfer (held-out gains 0.3 "
      "and 0.3)"};
  EXPECT_FALSE(t.correct());
  t.verdict = {"relaxation_length", "load_transfer"};
  EXPECT_TRUE(t.correct());
  // A pair's member not told from another beside the same partner: the note ties the two
  // members, never the partner it names after them.
  t.truth.effect = "brake_threshold";
  t.truth.effect2 = "time_offset";
  t.verdict = {"time_offset", "slip_offset"};
  t.notes = {
      "the data cannot separate slip_offset from brake_threshold beside time_offset: the pair "
      "with either explains the gap alike (held-out gains 0.894 and 0.878)"};
  EXPECT_TRUE(t.correct());
  EXPECT_FALSE(t.exact());
  t.truth.effect2 = "wheel_inertia";
  t.verdict = {"time_offset", "wheel_inertia"};
  EXPECT_FALSE(t.correct());
  t.truth.effect = "brake_threshold";
  t.truth.effect2 = "time_offset";
  t.verdict = {"brake_threshold", "relaxation_length"};
  // At one speed a relaxation and a time offset are one lag: either name counts for the other.
  t.notes.clear();
  EXPECT_FALSE(t.correct());
  t.one_speed = true;
  EXPECT_TRUE(t.correct());
  EXPECT_FALSE(t.exact());
}

TEST(GapPairs, ABrakeThresholdAndASlipOffsetAreBothNamedWithTheirMagnitudes) {
  sim::Injection inj{"brake_threshold", 3.0, gap::Condition::Roller};
  inj.effect2 = "slip_offset";
  inj.magnitude2 = -0.006;
  const auto t = sim::run_trial(inj, 7, gap::calibrated_options(inj.condition));
  EXPECT_TRUE(t.correct()) << ::testing::PrintToString(t.verdict);
  EXPECT_NEAR(t.estimate, inj.magnitude, 0.15 * inj.magnitude);
  EXPECT_NEAR(t.estimate2, inj.magnitude2, 0.15 * std::abs(inj.magnitude2));
  EXPECT_LT(t.gap_after_n, 1.5 * t.noise_n);
}

TEST(GapPairs, AHeavyWheelUnderLoadTransferIsFoundAsAPairWhereNeitherPassesAlone) {
  // On the ground a wheel inertia and load transfer bend the curve against each other: alone
  // neither passes the gates (the set was `unexplained`, 47 N of structured gap left); fitted
  // together they explain 91 % of it.
  sim::Injection inj{"load_transfer", 0.0471, gap::Condition::Ground};
  inj.effect2 = "wheel_inertia";
  inj.magnitude2 = 1.698;
  const auto t = sim::run_trial(inj, 801018, gap::calibrated_options(inj.condition));
  EXPECT_TRUE(t.correct()) << ::testing::PrintToString(t.verdict);
  bool searched = false;
  for (const auto& n : t.notes) searched |= n.find("fitted together") != std::string::npos;
  EXPECT_TRUE(searched);
  // Both first, in either order: the pair search puts first the member that adds more over the
  // other alone, and since load transfer's law carries the body's pitch mode that is the inertia.
  ASSERT_GE(t.verdict.size(), 2u);
  EXPECT_EQ((std::set<std::string>{t.verdict[0], t.verdict[1]}),
            (std::set<std::string>{"load_transfer", "wheel_inertia"}));
  EXPECT_NEAR(t.estimate2, inj.magnitude2, 0.1 * inj.magnitude2);
  EXPECT_NEAR(t.estimate, inj.magnitude, 0.25 * inj.magnitude);
  // The pairs the search fitted (the report's pairs_tried, --why's "pair" lines), in the order
  // judged: each refused one says why, the named one is these two, the rest were not judged.
  int tried = 0, named = 0;
  for (const auto& s : t.scores) {
    if (s.rfind("pair ", 0) != 0) continue;
    ++tried;
    if (s.ends_with(", named")) {
      ++named;
      EXPECT_NE(s.find("load_transfer"), std::string::npos) << s;
      EXPECT_NE(s.find("wheel_inertia"), std::string::npos) << s;
    } else if (named > 0) {
      EXPECT_TRUE(s.find("a pair with less") != std::string::npos ||
                  s.find("at the end of its physical range") != std::string::npos)
          << s;
    }
  }
  EXPECT_EQ(named, 1) << brakefit::test::why_of(t);
  EXPECT_GE(tried, 10) << brakefit::test::why_of(t);
}

TEST(GapPairs, APairReplacesTwoNamedEffectsThatLeaveAStructuredGap) {
  // Generator B's ground: a heavy wheel (2.1 kg m^2) under load transfer, the vehicle's body
  // pitching. One effect at a time, a relaxation came first and a brake threshold second, 110 N
  // of structured gap left. Searched in pairs once two were named, the inertia and load transfer
  // together leave 54 N held out and replace them.
  sim::Injection inj{"wheel_inertia", 2.128, gap::Condition::Ground, sim::Generator::B};
  inj.effect2 = "load_transfer";
  inj.magnitude2 = 0.04647;
  const auto t = sim::run_trial(inj, 801007, gap::calibrated_options(inj.condition));
  EXPECT_TRUE(t.correct()) << ::testing::PrintToString(t.verdict);
  bool replaced = false;
  for (const auto& n : t.notes)
    replaced |= n.find("the first took part of its partner's bend") != std::string::npos;
  EXPECT_TRUE(replaced);
  for (const char* e : {"relaxation_length", "brake_threshold"})
    EXPECT_EQ(std::count(t.verdict.begin(), t.verdict.end(), e), 0)
        << ::testing::PrintToString(t.verdict);
  // The 15 % is a median over the referee's pairs (docs/gap_results.md); on this set load
  // transfer takes part of the inertia's bend (1.78 kg m^2, q 0.066 for 0.046).
  EXPECT_NEAR(t.estimate, inj.magnitude, 0.2 * inj.magnitude);
}

TEST(GapPairs, AWheelsInertiaIsInALateChannelAsLateAsTheTyresForce) {
  // Every generator delays the pressure channel as a whole: the brake torque it reads is the
  // tyre's force and the wheel's inertial force of dt ago. Read at t, the inertia's term fitted
  // 0.42 kg m^2 for 2.56 beside the time offset on generator B's roller. With the encoders and
  // the pressure ideal (nothing else in the way) both are found at their values.
  auto set = sim2::draw_set(can::BenchKind::Roller,
                            {{"time_offset", 0.02852}, {"wheel_inertia", 2.562}}, 4242);
  const std::vector<gap::Run> runs = test::ideal_runs(set);
  const auto rep =
      gap::diagnose(runs, sim::pooled_start(runs), gap::calibrated_options(gap::Condition::Roller));
  const auto at = [&](gap::Effect e) { return gap::param_offset(rep.accepted, e); };
  ASSERT_TRUE(at(gap::Effect::TimeOffset)) << ::testing::PrintToString(rep.verdict);
  ASSERT_TRUE(at(gap::Effect::WheelInertia)) << ::testing::PrintToString(rep.verdict);
  EXPECT_NEAR(rep.after.params[*at(gap::Effect::WheelInertia)], 2.562, 0.03 * 2.562);
  EXPECT_NEAR(rep.after.params[*at(gap::Effect::TimeOffset)], 0.02852, 0.03 * 0.02852);
}

TEST(GapPairs, ABrakeThresholdBesideASlipOffsetIsToldByTheWheelsRest) {
  // On the ground the dead zone and the foot's shift are one line in the linear region: the
  // offset alone fits below where the wheel rested (B's pairs were said `slip_offset`). The rest
  // shows the offset; what the fit put beyond it is the threshold's force without slip.
  for (const double offset : {-0.009, 0.009}) {
    sim::Injection inj{"brake_threshold", 1.3, gap::Condition::Ground, sim::Generator::B};
    inj.effect2 = "slip_offset";
    inj.magnitude2 = offset;
    const auto t = sim::run_trial(inj, 23, gap::calibrated_options(inj.condition));
    EXPECT_TRUE(t.correct()) << offset << ": " << ::testing::PrintToString(t.verdict);
    EXPECT_NEAR(t.estimate, inj.magnitude, 0.15 * inj.magnitude) << offset;
    EXPECT_NEAR(t.estimate2, offset, 0.05 * std::abs(offset));
    EXPECT_TRUE(std::any_of(t.notes.begin(), t.notes.end(), [](const std::string& n) {
      return n.find("below the slip the wheel rested at") != std::string::npos;
    })) << offset;
  }
}

TEST(GapPairs, AnEffectIsNotTakenWhereItPushesAnEffectNamedBeforeItToItsRangesEnd) {
  // The referee's ground pair 33 (generator A, seed 1): a 0.028 s time offset with a slip offset.
  // Load transfer leads (it takes the offset's bend); refitted beside a brake threshold or a slip
  // offset in round 2 its load ran to the end of its range. That joint fit was taken, and the set
  // was said `load_transfer, brake_threshold, relaxation_length, unexplained`: each added name
  // traded the first one's law for its own.
  const auto [inj, res, why] = referee_pair(gap::Condition::Ground, sim::Generator::A, 33);
  ASSERT_EQ(inj.effect, "slip_offset");
  ASSERT_EQ(inj.effect2, "time_offset");
  for (const char* e : {"brake_threshold", "relaxation_length", "load_transfer"})
    EXPECT_EQ(std::count(res.verdict.begin(), res.verdict.end(), e), 0) << e << why;
  // Alone the time offset fits short (0.0098 s: the offset's shift takes part of the delay) and
  // the slip offset's BIC drop ranks fifth: the two are found together only where every pair of
  // round 1's candidates is tried, and the pair kept is the best one held out that passes. The
  // wheel rests 11 N above the pair's fitted foot (3.5 floors): less than a rolling wheel carries
  // at rest, so no brake threshold is read from it (counted above).
  EXPECT_TRUE(res.correct()) << ::testing::PrintToString(res.verdict) << why;
  EXPECT_NEAR(res.estimate, inj.magnitude, 0.15 * std::abs(inj.magnitude));
  EXPECT_NEAR(res.estimate2, inj.magnitude2, 0.15 * inj.magnitude2);
}

TEST(GapPairs, ThePairNamedIsTheBestHeldOutThatPassesNotTheBestHeldOut) {
  // The referee's roller pair 5 (generator B, seed 1): a slip offset with a 0.15 m relaxation.
  // One effect at a time a lag is named and a structured gap left. In pairs, a relaxation with a
  // brake threshold leaves the least held out but fails the gates; a lag with the slip offset,
  // next held out, passes. Taking only the best held out and checking it, the set stayed
  // `unexplained` with the offset unnamed (this test fails so).
  const auto [inj, res, why] = referee_pair(gap::Condition::Roller, sim::Generator::B, 5);
  ASSERT_EQ(inj.effect, "slip_offset");
  ASSERT_EQ(inj.effect2, "relaxation_length");
  EXPECT_TRUE(res.correct()) << ::testing::PrintToString(res.verdict) << why;
  EXPECT_TRUE(std::any_of(res.notes.begin(), res.notes.end(), [](const std::string& n) {
    return n.find("fitted together") != std::string::npos;
  })) << why;
}

TEST(GapPairs, AThresholdsDeadZoneIsReadOnTheLinesPressureBehindADeclaredFilter) {
  // The referee's roller pair 36 (generator B, seed 1): a 0.39 m relaxation with a 2.8 bar
  // threshold, ramps up to 60 bar/s through a declared 12 ms pressure filter. Read on the channel,
  // the wheel moved a full curve's slip while the channel rose to about 60 % of p0 (the line was
  // past it), and a run that starts above a quarter of p0 was measured from its first sample, a
  // quantisation step below its rest: the threshold was refused (the slip moved 101 % as much as
  // the curve gives) and the set said `relaxation_length, slip_offset, unexplained`.
  const auto [inj, res, why] = referee_pair(gap::Condition::Roller, sim::Generator::B, 36);
  ASSERT_EQ(inj.effect, "relaxation_length");
  ASSERT_EQ(inj.effect2, "brake_threshold");
  EXPECT_TRUE(res.correct()) << ::testing::PrintToString(res.verdict) << why;
  EXPECT_NEAR(res.estimate2, inj.magnitude2, 0.15 * inj.magnitude2) << why;
}

TEST(GapPairs, ACradleCapBehindALateChannelIsNamedWithIt) {
  // The referee's roller pair 26 (generator A, seed 1): behind a 49 ms late pressure channel the
  // runs read their runaway at 3084-3247 N (a fast ramp's lowest), 5 % apart, and the set said
  // only the offset. Read dt earlier each runs away at the cap, which the curve fitted with the
  // offset passes (1.2x).
  {
    const auto [inj, res, why] = referee_pair(gap::Condition::Roller, sim::Generator::A, 26);
    ASSERT_EQ(inj.effect, "time_offset");
    ASSERT_EQ(inj.effect2, "cradle_cap");
    EXPECT_TRUE(res.correct()) << ::testing::PrintToString(res.verdict) << why;
    EXPECT_NEAR(res.estimate2, inj.magnitude2, 0.02 * inj.magnitude2) << why;
  }
  // A late channel beside a wheel's inertia runs away at the tyre's peak: no cap (pair 1).
  const auto [inj, res, why] = referee_pair(gap::Condition::Roller, sim::Generator::A, 1);
  ASSERT_EQ(inj.effect2, "time_offset");
  EXPECT_EQ(std::count(res.verdict.begin(), res.verdict.end(), "cradle_cap"), 0) << why;
}

TEST(GapPairs, ALagNamedBeforeItsPartnerIsChosenAgainBesideIt) {
  // The referee's ground pair 2 (generator B, seed 1): a 6.8 ms late channel with load transfer.
  // In round 1 load transfer ends on its range's bound, and a relaxation length takes the lag's
  // place first; load transfer is named after it and the set said `relaxation_length,
  // load_transfer, unexplained` (this test fails so). With load transfer in the model the time
  // offset in the relaxation's place leaves about half as much held out; the runs' speeds, 2.4x
  // apart, tell the two apart.
  const auto [inj, res, why] = referee_pair(gap::Condition::Ground, sim::Generator::B, 2);
  ASSERT_EQ(inj.effect, "load_transfer");
  ASSERT_EQ(inj.effect2, "time_offset");
  EXPECT_TRUE(res.correct()) << ::testing::PrintToString(res.verdict) << why;
  EXPECT_EQ(std::count(res.verdict.begin(), res.verdict.end(), "relaxation_length"), 0) << why;
  // The generator sets the truth in the diagnosis's units (load transfer per m/s^2).
  EXPECT_NEAR(res.estimate, res.truth.magnitude, 0.15 * res.truth.magnitude) << why;
  EXPECT_NEAR(res.estimate2, res.truth.magnitude2, 0.15 * res.truth.magnitude2) << why;
  EXPECT_TRUE(std::any_of(res.notes.begin(), res.notes.end(), [](const std::string& n) {
    return n.find("is named instead") != std::string::npos;
  })) << why;
}

TEST(GapPairs, AnEffectTheEffectsNamedAfterItMakeNeedlessIsDropped) {
  // The referee's ground pair 14 (generator A, seed 1): a 23.6 ms late channel with a 2.6 kg m^2
  // wheel. A relaxation length took the lag's place in round 1, the inertia and a time offset
  // (7.2 ms, a third of the truth) came after it, 24.4 N left held out. Without the relaxation
  // the two leave 6.1 N: it is dropped, and both are named at their magnitudes.
  const auto [inj, res, why] = referee_pair(gap::Condition::Ground, sim::Generator::A, 14);
  ASSERT_EQ(inj.effect, "time_offset");
  ASSERT_EQ(inj.effect2, "wheel_inertia");
  EXPECT_TRUE(res.correct()) << ::testing::PrintToString(res.verdict) << why;
  EXPECT_EQ(std::count(res.verdict.begin(), res.verdict.end(), "relaxation_length"), 0) << why;
  EXPECT_NEAR(res.estimate, res.truth.magnitude, 0.05 * res.truth.magnitude) << why;
  EXPECT_NEAR(res.estimate2, res.truth.magnitude2, 0.05 * res.truth.magnitude2) << why;
  EXPECT_TRUE(std::any_of(res.notes.begin(), res.notes.end(), [](const std::string& n) {
    return n.find("does not earn its place") != std::string::npos;
  })) << why;
}

TEST(GapPairs, LoadTransferWithSpeedFrictionIsJudgedOnAllRuns) {
  // The referee's ground pair 3 (generator B, seed 1): load transfer with speed friction. Held
  // out, a fold fitted on two of the three runs trades the tyre's shape for the load and misses
  // the third run by hundreds of newtons, so no candidate and no pair passed and the set said
  // `unexplained` (this test fails so). Fitted together on all runs the two leave the floor.
  const auto [inj, res, why] = referee_pair(gap::Condition::Ground, sim::Generator::B, 3);
  ASSERT_EQ(inj.effect, "load_transfer");
  ASSERT_EQ(inj.effect2, "speed_friction");
  EXPECT_TRUE(res.correct()) << ::testing::PrintToString(res.verdict) << why;
  EXPECT_NEAR(res.estimate2, res.truth.magnitude2, 0.15 * res.truth.magnitude2) << why;
  EXPECT_TRUE(std::any_of(res.notes.begin(), res.notes.end(), [](const std::string& n) {
    return n.find("N in-sample") != std::string::npos;
  })) << why;
}

TEST(GapPairs, SpeedFrictionFallsWithTheSlidingOfTheSlipTheCurveIsReadAt) {
  // A tyre's friction falls with the contact's sliding speed: behind a relaxation length that is
  // the transient slip's, which lags the encoders' by sigma / V. Read on the encoders' slip the
  // friction falls too early and comes out a quarter low. Generator B's ground, the encoders and
  // the pressure ideal: both are found at their values.
  auto set = sim2::draw_set(can::BenchKind::Ground,
                            {{"relaxation_length", 0.3}, {"speed_friction", 1.5}}, 4343);
  const std::vector<gap::Run> runs = test::ideal_runs(set);
  const std::vector<gap::Effect> model{gap::Effect::RelaxationLength, gap::Effect::SpeedFriction};
  const gap::Fit f = gap::fit_runs(gap::pointers(runs), model, sim::pooled_start(runs));
  EXPECT_NEAR(f.params[4], 0.3, 0.03 * 0.3);
  EXPECT_NEAR(f.params[5], 1.5, 0.06 * 1.5);  // 1.44; read on the encoders' slip, 1.15
}

TEST(GapPairs, AMemberAnotherCandidateReplacesAlikeIsSaidInseparable) {
  // The referee's roller pair 34 (generator B, seed 1): a 1.72 bar threshold with a 43 ms late
  // channel. Beside the lag a slip offset explains 0.894 of the gap, the threshold 0.878: both
  // shift the curve's foot. The pair with the offset is named, and the report says the two
  // cannot be told apart there (it said `time_offset, slip_offset`, the threshold unmentioned).
  const auto [inj, res, why] = referee_pair(gap::Condition::Roller, sim::Generator::B, 34);
  ASSERT_EQ(inj.effect, "brake_threshold");
  ASSERT_EQ(inj.effect2, "time_offset");
  EXPECT_TRUE(res.correct()) << ::testing::PrintToString(res.verdict) << why;
  EXPECT_TRUE(std::any_of(res.notes.begin(), res.notes.end(), [](const std::string& n) {
    return n.find("cannot separate slip_offset from brake_threshold beside time_offset") !=
           std::string::npos;
  })) << why;
}
