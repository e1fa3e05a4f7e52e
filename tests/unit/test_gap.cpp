// The gap diagnosis on simulated runs whose effects are known.
#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"
#include "core/gap/realign.hpp"
#include "core/pipeline/pipeline.hpp"
#include "sim/referee.hpp"
#include "sim/simulator.hpp"
#include "tests/unit/sim_test_util.hpp"

using namespace brakefit;
using brakefit::test::scenario;

namespace {

/// Three runs at different pedal ramps (slow, medium, fast), the same effects.
std::vector<gap::Run> runs(const sim::Scenario& s, MfParams* truth = nullptr) {
  auto out = sim::simulate_runs(s, s.seed, truth);
  EXPECT_EQ(out.size(), 3u);
  return out;
}

void print(const gap::Report& r) {
  std::cout << "verdict:";
  for (const auto& v : r.verdict) std::cout << " " << v;
  std::cout << "\n  gap before " << r.gap_before_rmse_n << " N, after " << r.gap_after_rmse_n
            << " N, noise " << r.noise_n << " N\n";
  for (const auto& e : r.effects)
    std::cout << "  " << gap::to_string(e.effect) << " " << e.params[0].first << "="
              << e.params[0].second << " gain " << e.gain << " dBIC " << e.delta_bic
              << (e.accepted ? " ACCEPTED" : "") << "\n";
  for (const auto& n : r.notes) std::cout << "  note: " << n << "\n";
}

/// An event of samples dt_s apart at these slips (up to 0.95): the reference slowing from v0_mps
/// by decel_mps2, the line's pressure rising from p0_bar at bar_per_s.
pipeline::Event event_at_slips(can::BenchKind bench, const std::vector<double>& slips, double dt_s,
                               double v0_mps, double decel_mps2, double p0_bar, double bar_per_s) {
  pipeline::Event e;
  e.bench = bench;
  for (std::size_t i = 0; i < slips.size(); ++i) {
    const double t = dt_s * static_cast<double>(i);
    pipeline::Sample smp;
    smp.t_ns = static_cast<std::int64_t>(std::llround(t * 1e9));
    smp.v_ref_mps = v0_mps - decel_mps2 * t;
    smp.v_wheel_mps = smp.v_ref_mps * (1 - std::min(slips[i], 0.95));
    smp.pressure_bar = p0_bar + bar_per_s * t;
    e.samples.push_back(smp);
  }
  return e;
}

pipeline::Calibration calibration(can::BenchKind bench, double brake_gain_n_per_bar) {
  pipeline::Calibration c;
  c.bench = bench;
  c.brake_gain_n_per_bar = brake_gain_n_per_bar;
  return c;
}

}  // namespace

TEST(GapCondition, NoiseAlignmentStartStateAndLockCutOnASyntheticStop) {
  // A 250 bar/s ramp with 0.05 bar of noise at 1 kHz: slip rises linearly, the wheel locks at the
  // end. The encoder speeds are the means over the last frame (half a frame late).
  pipeline::Event e;
  pipeline::Calibration c;
  c.brake_gain_n_per_bar = 66.7;
  Rng rng(3);
  const double rate_per_s = 0.2;  // slip rate
  double v_wheel_prev = 10.0;
  for (int i = 0; i < 400; ++i) {
    const double t = i * 1e-3;
    const double slip = std::min(1.0, 0.004 + rate_per_s * t + (t > 0.35 ? 40 * (t - 0.35) : 0));
    const double v_wheel = 10.0 * (1 - slip);
    pipeline::Sample smp;
    smp.t_ns = static_cast<std::int64_t>(std::llround(t * 1e9));
    smp.v_ref_mps = 10.0;
    smp.v_wheel_mps = 0.5 * (v_wheel + v_wheel_prev);  // mean over the last frame
    v_wheel_prev = v_wheel;
    smp.pressure_bar = 2.0 + 250.0 * t + 0.05 * rng.normal();
    e.samples.push_back(smp);
  }
  gap::ConditionOptions o;
  o.max_points = 1000;
  const gap::Run r = gap::condition("synthetic", e, c, o);
  // Noise from second differences: the 16 N per sample of the ramp is not counted.
  EXPECT_NEAR(r.noise_n, 66.7 * 0.05, 0.5);
  // The lock-up (slip jumping 0.04 per sample past 0.05) is cut.
  EXPECT_LT(r.t_s.back(), 0.352);
  EXPECT_GT(r.t_s.back(), 0.34);
  // Aligned: the slip at each stamp is the slip of that moment (not half a frame earlier).
  for (std::size_t i = 20; i + 20 < r.slip.size(); i += 37)
    EXPECT_NEAR(r.slip[i], 0.004 + rate_per_s * r.t_s[i], 2e-5) << r.t_s[i];
  EXPECT_NEAR(r.initial_slip_rate_per_s, rate_per_s, 0.01);
  EXPECT_NEAR(r.initial_force_n, 66.7 * 2.0, 4.0);
}

TEST(GapCondition, AGroundRunawayIsKeptWhereTheChannelFallsWithTheTyreAndCutWhereItRises) {
  // A ground stop at 500 Hz whose wheel runs away at 0.3 s (slip 0.12 -> lock in 30 ms). A brake's
  // line pressure rises on through the runaway: not the tyre's force there, cut. A channel that
  // falls with the slip (the tyre past its peak: a hub transducer, generator C's perfect brake)
  // shows the tyre: kept up to the lock. On the roller the runaway is cut either way.
  auto stop = [](bool tyre_channel, can::BenchKind bench) {
    pipeline::Event e;
    e.bench = bench;
    for (int i = 0; i < 200; ++i) {
      const double t = i * 2e-3;
      const double slip = t < 0.3 ? 0.4 * t : std::min(0.95, 0.12 + 30 * (t - 0.3));
      const double tyre_n = t < 0.3 ? 10000 * t : 3000 - 1000 * (slip - 0.12);
      pipeline::Sample smp;
      smp.t_ns = static_cast<std::int64_t>(std::llround(t * 1e9));
      smp.v_ref_mps = 15.0;
      smp.v_wheel_mps = 15.0 * (1 - slip);
      smp.pressure_bar = (tyre_channel ? tyre_n : 10000 * t) / 60.0;
      e.samples.push_back(smp);
    }
    pipeline::Calibration c;
    c.bench = bench;
    c.brake_gain_n_per_bar = 60.0;
    gap::ConditionOptions o;
    o.max_points = 1000;
    return gap::condition("stop", e, c, o);
  };
  const gap::Run brake = stop(false, can::BenchKind::Ground);
  EXPECT_TRUE(brake.runaway);
  EXPECT_LT(brake.t_s.back(), 0.304);
  const gap::Run tyre = stop(true, can::BenchKind::Ground);
  EXPECT_FALSE(tyre.runaway);
  EXPECT_GT(tyre.t_s.back(), 0.32);                                       // past the runaway
  EXPECT_LT(*std::max_element(tyre.slip.begin(), tyre.slip.end()), 0.9);  // but not locked
  EXPECT_GT(*std::max_element(tyre.slip.begin(), tyre.slip.end()), 0.6);
  const gap::Run roller = stop(true, can::BenchKind::Roller);
  EXPECT_TRUE(roller.runaway);
}

TEST(GapCondition, ARunawayIsASlipRateNotAJumpPerSample) {
  // A roller run at 5 km/h exported at 100 Hz: past 3 % the slip rises at 3 /s (0.03 a sample,
  // the wheel losing 4 m/s^2 before it locks: a heavy wheel's inertial force, the tyre still
  // on its curve), then at 30 /s from 10 %. Cut where it runs away, not at the first 0.01 jump.
  std::vector<double> slips;
  for (int i = 0; i < 80; ++i) {
    const double t = i * 0.01;
    slips.push_back(t < 0.6 ? 0.05 * t
                            : (t < 0.6233 ? 0.03 + 3 * (t - 0.6) : 0.1 + 30 * (t - 0.6233)));
  }
  const pipeline::Event e = event_at_slips(can::BenchKind::Roller, slips, 0.01, 1.39, 0, 0, 50);
  const pipeline::Calibration c = calibration(can::BenchKind::Roller, 60.0);
  gap::ConditionOptions o;
  o.max_points = 1000;
  const gap::Run r = gap::condition("slow runaway", e, c, o);
  EXPECT_TRUE(r.runaway);
  EXPECT_GT(r.t_s.back(), 0.615);  // the slow part kept
  EXPECT_LT(r.t_s.back(), 0.635);  // the fast part cut
  o.runaway_slip_per_s = 0;        // judged per sample alone: cut at the first 0.01 jump
  EXPECT_LT(gap::condition("slow runaway", e, c, o).t_s.back(), 0.605);
}

TEST(GapCondition, ATrucksLinearRampAt50HzOnTheRoadIsNotARunaway) {
  // Generator B's truck at 57 km/h exported at 50 Hz: its air brake ramps the slip from 3 % by
  // 0.012 a sample (0.6 /s) to 11 %, then the wheel runs away (0.19 and 0.7 a sample). A jump of
  // 0.01 per sample cuts the run after two samples, too few: at 4 /s it is cut where the wheel
  // runs away.
  const std::vector<double> slips{0.033, 0.032, 0.041, 0.053, 0.060,
                                  0.069, 0.084, 0.106, 0.298, 0.95};
  const pipeline::Event e = event_at_slips(can::BenchKind::Ground, slips, 0.02, 15.9, 5.0, 0.3, 12);
  const pipeline::Calibration c = calibration(can::BenchKind::Ground, 4000.0);
  gap::ConditionOptions o;
  o.smooth_half_window = 0;
  const gap::Run r = gap::condition("truck at 50 Hz", e, c, o);
  EXPECT_TRUE(r.runaway);
  EXPECT_EQ(r.t_s.size(), 8u);      // up to 10.6 % slip
  o.ground_runaway_slip_per_s = 0;  // per sample alone: cut at 0.041 -> 0.053
  EXPECT_THROW(gap::condition("truck at 50 Hz", e, c, o), InputError);
  // Where the jump per sample leaves enough, it stands: a slower ramp to 4 % (0.004 a sample)
  // and then the same ramp from 4.1 % are cut at its first 0.012 jump, past 8 samples.
  std::vector<double> ramp;
  for (int i = 0; i < 10; ++i) ramp.push_back(0.004 * i);
  for (double x : slips)
    if (x > 0.04) ramp.push_back(x);
  const pipeline::Event longer =
      event_at_slips(can::BenchKind::Ground, ramp, 0.02, 15.9, 5.0, 0.3, 12);
  o.ground_runaway_slip_per_s = 4.0;
  const gap::Run cut = gap::condition("truck at 50 Hz, slower", longer, c, o);
  EXPECT_TRUE(cut.runaway);
  EXPECT_EQ(cut.t_s.size(), 11u);  // up to 4.1 %: 0.041 -> 0.053 jumps by more than 0.01
}

TEST(Gap, WheelInertiaIsFoundFirst) {
  // Only the wheel's real inertia (1 kg m^2) differs from the 4-parameter model.
  sim::Scenario s = scenario("ideal_roller");
  s.effects.pressure_noise_bar = 0.05;
  MfParams truth;
  const auto rs = runs(s, &truth);
  const gap::Report r = gap::diagnose(rs, truth);
  print(r);
  ASSERT_FALSE(r.verdict.empty());
  EXPECT_EQ(r.verdict.front(), "wheel_inertia");
  // The fit's parameters follow the model (the baseline's nuisance terms first): found by name.
  const auto names = gap::param_names(r.accepted);
  const auto at = std::find(names.begin(), names.end(), "inertia_kgm2");
  ASSERT_NE(at, names.end());
  const double inertia = r.after.params.at(static_cast<std::size_t>(at - names.begin()));
  EXPECT_NEAR(inertia, 1.0, 0.25);  // magnitude within 25 % (measured 1.01)
  EXPECT_LT(r.gap_after_rmse_n, r.gap_before_rmse_n);
  EXPECT_LT(r.gap_after_rmse_n, 1.2 * r.noise_n);
}

TEST(Gap, NoEffectIsNamedWhereTheBaselineFitsWithinTheFloor) {
  // A wheel inertia whose term the baseline misses, on runs whose floor says more noise than
  // the baseline's held-out gap (generator B's ground null sets' gaps sit at 0.36-0.85 x their
  // floors): a candidate passes the gates, but nothing beyond the floor is left to explain.
  sim::Scenario s = scenario("ideal_roller");
  s.effects.pressure_noise_bar = 0.05;
  s.wheel_inertia_kgm2 = 0.5;
  MfParams truth;
  auto rs = runs(s, &truth);
  gap::Options off;
  off.min_gap_over_floor = 0.0;
  const gap::Report plain = gap::diagnose(rs, truth, off);
  ASSERT_FALSE(plain.verdict.empty());
  ASSERT_EQ(plain.verdict.front(), "wheel_inertia");  // the rule off: the candidate is named
  // With its honest floor this set sits at 0.95 x it (3.76 N on 3.96 N: the floor is an
  // estimate), above the rule's 0.9: named with the rule on as well.
  EXPECT_GT(plain.gap_before_rmse_n, 0.9 * plain.noise_n);
  ASSERT_EQ(gap::diagnose(rs, truth).verdict.front(), "wheel_inertia");
  for (auto& r : rs) r.noise_n = 1.5 * plain.gap_before_rmse_n;  // a floor that says more noise
  const gap::Report r = gap::diagnose(rs, truth);
  print(r);
  EXPECT_LT(r.gap_before_rmse_n, 0.9 * r.noise_n);
  EXPECT_EQ(r.verdict, std::vector<std::string>{"none"});
  EXPECT_TRUE(std::none_of(r.effects.begin(), r.effects.end(),
                           [](const gap::EffectScore& e) { return e.accepted; }));
  bool noted = false;
  for (const auto& n : r.notes) noted |= n.find("within the noise floor") != std::string::npos;
  EXPECT_TRUE(noted);
  // Above 0.9 x the floor the same candidate is named.
  for (auto& run : rs) run.noise_n = 0.8 * plain.gap_before_rmse_n;
  const gap::Report above = gap::diagnose(rs, truth);
  ASSERT_FALSE(above.verdict.empty());
  EXPECT_EQ(above.verdict.front(), "wheel_inertia");
}

TEST(Gap, BrakeThresholdIsFoundWithItsMagnitude) {
  sim::Scenario s = scenario("ideal_roller");
  s.effects.wheel_inertia = false;  // negligible inertia: a true null
  s.effects.pressure_noise_bar = 0.05;
  s.effects.brake_threshold_bar = 3.0;
  MfParams truth;
  const auto rs = runs(s, &truth);
  const gap::Report r = gap::diagnose(rs, truth);
  print(r);
  // A constant force offset and a slip offset look alike in the linear region; the dead zone
  // below p0 (pressure without slip) tells them apart.
  ASSERT_FALSE(r.verdict.empty());
  EXPECT_EQ(r.verdict.front(), "brake_threshold");
  for (const auto& e : r.effects) {
    if (e.effect == gap::Effect::BrakeThreshold) {
      EXPECT_NEAR(e.params[0].second, 3.0, 0.75);  // magnitude within 25 %
      EXPECT_GT(e.gain, 0.8);
    }
  }
  EXPECT_LT(r.gap_after_rmse_n, 0.15 * r.gap_before_rmse_n);
  EXPECT_LT(r.gap_after_rmse_n, 1.2 * r.noise_n);
  // Where forward selection stopped: round 2, every other candidate scored beside the threshold,
  // none taken, each with its reason (what a reader of the verdict asks next).
  ASSERT_EQ(r.verdict, std::vector<std::string>{"brake_threshold"});
  ASSERT_FALSE(r.stopping_round.empty());
  for (const auto& e : r.stopping_round) {
    EXPECT_EQ(e.round, 1) << gap::to_string(e.effect);
    EXPECT_FALSE(e.accepted);
    EXPECT_NE(e.effect, gap::Effect::BrakeThreshold);
    EXPECT_FALSE(e.decision.empty()) << gap::to_string(e.effect);
    EXPECT_LT(e.gain, 0.5) << gap::to_string(e.effect);  // the threshold left nothing to take
  }
  // The runs' spread of every parameter of the model named: three folds, each left out.
  ASSERT_EQ(r.after_spread.size(), r.after.params.size());
  const auto names = gap::param_names(r.accepted);
  const auto p0 =
      static_cast<std::size_t>(std::find(names.begin(), names.end(), "p0_bar") - names.begin());
  ASSERT_LT(p0, r.after_spread.size());
  EXPECT_GT(r.after_spread[p0], 0.0);
  EXPECT_LT(r.after_spread[p0], 0.25);  // bar: the three ramps agree on one dead zone
}

TEST(Gap, ACradleCapIsFoundFromTheRunawayOrFittedWithTheWheelInertia) {
  // A light wheel runs away within milliseconds of the cap: the cap leaves no residual and is
  // found from how the runs end (one force, still rising with slip). A real wheel (1 kg m^2) runs
  // away gradually: the cap is fitted, jointly with the wheel's inertia.
  for (const double inertia_kgm2 : {0.005, 1.0}) {
    sim::Scenario s = sim::referee_null(can::BenchKind::Roller);
    s.wheel_inertia_kgm2 = inertia_kgm2;
    s.effects.cradle_cap_ratio = 3000.0 / s.wheel_load_n;
    const auto rs = sim::simulate_runs(s, 21);
    ASSERT_GE(rs.size(), 2u);
    auto ev = gap::cradle_cap_evidence(rs);
    EXPECT_EQ(ev.has_value(), inertia_kgm2 < 0.1) << inertia_kgm2;
    // A cap below the tyre's peak cuts a curve still rising: a Magic Formula fitted to the whole
    // runs peaks past it (a tyre's own sharp peak would put D at the runaway force).
    if (ev) {
      EXPECT_FALSE(gap::cap_at_fitted_peak(*ev, rs, sim::pooled_start(rs)));
      EXPECT_GT(ev->fitted_peak_ratio, 1.04);
    }
    const gap::Report r =
        gap::diagnose(rs, sim::pooled_start(rs), gap::calibrated_options(gap::Condition::Roller));
    print(r);
    ASSERT_FALSE(r.verdict.empty());
    EXPECT_EQ(r.verdict.front(), "cradle_cap") << inertia_kgm2;
    EXPECT_NEAR(r.cap_n, 3000.0, 0.05 * 3000.0) << inertia_kgm2;
    EXPECT_LT(r.gap_after_rmse_n, 1.2 * r.noise_n) << inertia_kgm2;
  }
  // Without the cap the runs run away at the tyre's peak: no cap evidence.
  const auto free_runs = sim::simulate_runs(sim::referee_null(can::BenchKind::Roller), 21);
  EXPECT_FALSE(gap::cradle_cap_evidence(free_runs).has_value());
}

TEST(Gap, TheTyresOwnShiftIsANuisanceNotASlipOffset) {
  // MF 6.1 tyres carry a horizontal shift (SHx, a slip of a few 1e-4: the foot of the curve off
  // zero slip). On null ground runs with the slip moved by 3e-4 the shift is levelled as a
  // nuisance term of every fit: none is named, the baseline carries it with its value; a real
  // slip offset (a radius error of 0.4 %) beyond it is still named with its magnitude.
  for (const double shift : {3e-4, 4e-3}) {
    auto rs = sim::simulate_runs(sim::referee_null(can::BenchKind::Ground), 5);
    ASSERT_GE(rs.size(), 3u);
    for (gap::Run& r : rs) {
      for (double& k : r.slip) k += shift;
      // An offset reads at rest too (the wheel rolling free): each rest sample moves by it.
      const auto n = static_cast<double>(r.rest_slip_points);
      r.rest_slip_sq_sum += 2 * shift * r.rest_slip_sum + n * shift * shift;
      r.rest_slip_sum += n * shift;
    }
    const gap::Report r =
        gap::diagnose(rs, sim::pooled_start(rs), gap::calibrated_options(gap::Condition::Ground));
    print(r);
    ASSERT_FALSE(r.verdict.empty());
    if (shift < 1e-3) {
      EXPECT_EQ(r.verdict, std::vector<std::string>{"none"});
      ASSERT_EQ(r.baseline_effects, std::vector<gap::Effect>{gap::Effect::TyreShift});
      EXPECT_NEAR(r.before.params.at(4), shift, 0.2 * shift);
      EXPECT_LT(r.gap_before_rmse_n, 1.5 * r.noise_n);
    } else {
      EXPECT_EQ(r.verdict.front(), "slip_offset");
      const auto names = gap::param_names(r.accepted);
      const auto at = std::find(names.begin(), names.end(), "slip_offset_ratio");
      ASSERT_NE(at, names.end());
      EXPECT_NEAR(r.after.params.at(static_cast<std::size_t>(at - names.begin())), shift,
                  0.1 * shift);
    }
  }
}

// A small subset of the blinded-injection referee (bench/gap_referee runs >= 200 trials).
TEST(Gap, AFittedCapNeedsTheKinkOnlyACapLeaves) {
  // A cap cuts the curve where it still rises: below it the force keeps at least 30 % of its
  // initial slope. A curve that is not a Magic Formula (Burckhardt's, flat-topped) flattens
  // gradually: a cap fitted to its top is not named (it cannot be told from the curve's shape).
  sim::Scenario capped = sim::referee_null(can::BenchKind::Roller);
  capped.wheel_inertia_kgm2 = 1.0;  // a real wheel: runs away gradually, the cap is fitted
  capped.effects.cradle_cap_ratio = 3000.0 / capped.wheel_load_n;
  EXPECT_GE(gap::cap_kink_ratio(sim::simulate_runs(capped, 21), 3000.0), gap::kCapMinEndSlopeRatio);
  sim::Injection mis{"misspecified", 0, gap::Condition::Roller, sim::Generator::A};
  for (std::uint64_t seed : {31u}) {
    const auto rs =
        sim::simulate_runs(sim::inject(sim::referee_null(can::BenchKind::Roller), mis), seed);
    double top_n = 0;
    for (const auto& r : rs)
      for (double f : r.force_n) top_n = std::max(top_n, f);
    EXPECT_LT(gap::cap_kink_ratio(rs, top_n), gap::kCapMinEndSlopeRatio) << seed;
    const gap::Report r =
        gap::diagnose(rs, sim::pooled_start(rs), gap::calibrated_options(gap::Condition::Roller));
    print(r);
    EXPECT_EQ(std::find(r.verdict.begin(), r.verdict.end(), "cradle_cap"), r.verdict.end()) << seed;
  }
}

TEST(GapCondition, AChannelReadLaterShowsEachMomentsForceAndEndsThatMuchEarlier) {
  // A ground stop at 500 Hz whose pressure channel is 80 ms late: it shows at t the line's
  // pressure at t - 0.08 (a ramp of 200 bar/s from 0.05 s). Read 80 ms later, each sample's force
  // is its own moment's; the run ends 80 ms before the record (no channel is there to read).
  std::vector<double> slips;
  for (int i = 0; i < 300; ++i) slips.push_back(0.05 * i * 2e-3);
  pipeline::Event e = event_at_slips(can::BenchKind::Ground, slips, 2e-3, 15.0, 3.0, 0, 0);
  const auto line_bar = [](double t) { return std::max(0.0, 200.0 * (t - 0.05)); };
  for (auto& s : e.samples) s.pressure_bar = line_bar(static_cast<double>(s.t_ns) * 1e-9 - 0.08);
  const pipeline::Calibration c = calibration(can::BenchKind::Ground, 60.0);
  gap::ConditionOptions o;
  o.max_points = 1000;
  const gap::Run late = gap::condition("late", e, c, o);
  o.channel_advance_s = 0.08;
  const gap::Run read = gap::condition("late", e, c, o);
  EXPECT_NEAR(late.t_s.back(), 0.598, 0.003);
  EXPECT_NEAR(read.t_s.back(), 0.518, 0.003);
  for (std::size_t i = 10; i + 10 < read.t_s.size(); i += 23) {
    EXPECT_NEAR(read.force_n[i], 60.0 * line_bar(read.t_s[i]), 5.0) << read.t_s[i];
    EXPECT_NEAR(read.slip[i], 0.05 * read.t_s[i], 2e-4) << read.t_s[i];
  }
  // The run keeps what it was conditioned from, the advance among its options.
  ASSERT_TRUE(read.source);
  EXPECT_EQ(read.source->options.channel_advance_s, 0.08);
  EXPECT_EQ(read.source->event.samples.size(), e.samples.size());
}

TEST(GapCondition, AdvancingAChannelTakesTheSampleNearestEachTimeAndShortensEveryArray) {
  // Nearest, not a mean of two: a mean would halve the noise the floor is read from.
  std::vector<double> t_s{0.0, 0.1, 0.2, 0.3, 0.4}, x{0, 10, 20, 40, 80}, other{1, 2, 3, 4, 5};
  gap::advance_channel(t_s, 0.13, {&x}, {&other});
  ASSERT_EQ(t_s.size(), 3u);  // 0.3 + 0.13 is past 0.4: read from nothing
  EXPECT_EQ(other, (std::vector<double>{1, 2, 3}));
  EXPECT_EQ(x, (std::vector<double>{10, 20, 40}));
  std::vector<double> t2{0.0, 0.1, 0.2, 0.3}, y{0, 10, 20, 40};
  gap::advance_channel(t2, 0.17, {&y}, {});
  EXPECT_EQ(y, (std::vector<double>{20, 40}));
}
