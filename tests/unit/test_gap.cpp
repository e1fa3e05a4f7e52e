// The gap diagnosis on simulated runs whose effects are known.
#include <gtest/gtest.h>

#include <algorithm>
#include <iostream>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"
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
TEST(GapReferee, StrongInjectionsAreNamedWithTheirMagnitude) {
  using gap::Condition;
  for (const sim::Injection& inj : {sim::Injection{"relaxation_length", 0.3, Condition::Roller},
                                    sim::Injection{"time_offset", 0.04, Condition::Roller},
                                    sim::Injection{"slip_offset", -0.006, Condition::Roller},
                                    sim::Injection{"wheel_inertia", 2.0, Condition::Ground}}) {
    const auto t = sim::run_trial(inj, 7, gap::calibrated_options(inj.condition));
    ASSERT_FALSE(t.verdict.empty()) << inj.effect;
    EXPECT_EQ(t.verdict.front(), inj.effect);
    EXPECT_TRUE(t.correct());
    EXPECT_NEAR(t.estimate, inj.magnitude, 0.25 * std::abs(inj.magnitude)) << inj.effect;
    // The gap left on withheld runs is within 1.2x the noise floor.
    EXPECT_LT(t.gap_after_n, 1.2 * t.noise_n) << inj.effect;
    EXPECT_LT(t.gap_after_n, 0.5 * t.gap_before_n) << inj.effect;
  }
}

TEST(GapReferee, LoadTransfersMagnitudeIsMeasuredAtThePublishedStiffnessRatio) {
  // Generator A's ground runs stop at 11-13 % slip, just past the peak: they fix how the slip
  // stiffness grows with the load (q x ratio) but not how the peak does. Referee trials 43 and 79
  // fitted the ratio at 1.9-2.3 and q at 0.011 and 0.010 for 0.0227 and 0.0221; held at the
  // published tyres' 1.25 once named, q is within 15 % (measured 0.0245, 0.0244).
  for (const auto& [magnitude, seed] : {std::pair{0.02269, 101043u}, std::pair{0.02211, 101079u}}) {
    const sim::Injection inj{"load_transfer", magnitude, gap::Condition::Ground};
    const auto t = sim::run_trial(inj, seed, gap::calibrated_options(gap::Condition::Ground));
    ASSERT_FALSE(t.verdict.empty());
    EXPECT_EQ(t.verdict.front(), "load_transfer") << "seed " << seed;
    EXPECT_NEAR(t.estimate, magnitude, 0.15 * magnitude) << "seed " << seed;
    // In the law's unit, the wheel load's change per m/s^2 (dFz/Fz), through published tyres'
    // d ln D / d ln Fz: the truth is the simulated tyre's.
    ASSERT_TRUE(std::isfinite(t.truth.load_per_decel));
    EXPECT_NEAR(t.load_per_decel_estimate, t.truth.load_per_decel, 0.15 * t.truth.load_per_decel)
        << "seed " << seed;
    bool noted = false;
    for (const auto& n : t.notes) noted |= n.find("load ratio held at") != std::string::npos;
    EXPECT_TRUE(noted) << "seed " << seed;
  }
}

TEST(GapReferee, LoadTransferIsGivenAsHOverLWhereTheMassIsKnown) {
  // The vehicle's mass given: h/L = 2 Fz (dFz/Fz per m/s^2) / m, against the simulated vehicle's
  // centre of gravity and wheelbase (trial 43's set, as above).
  const sim::Injection inj{"load_transfer", 0.02269, gap::Condition::Ground};
  const sim::Scenario s = sim::inject(sim::referee_null(can::BenchKind::Ground), inj);
  const auto runs = sim::simulate_runs(s, 101043);
  gap::Options o = gap::calibrated_options(gap::Condition::Ground);
  o.vehicle_mass_kg = s.vehicle_mass_kg;
  const gap::Report rep = gap::diagnose(runs, sim::pooled_start(runs), o);
  ASSERT_FALSE(rep.verdict.empty());
  ASSERT_EQ(rep.verdict.front(), "load_transfer");
  double h_over_l = NAN;
  for (const auto& e : rep.effects)
    if (e.accepted && e.effect == gap::Effect::LoadTransfer)
      for (const auto& [name, v] : e.params)
        if (name == "cg_height_over_wheelbase") h_over_l = v;
  const double truth = s.cg_height_m / s.wheelbase_m;
  EXPECT_NEAR(h_over_l, truth, 0.15 * truth);
  // Without the mass only dFz/Fz is given.
  const gap::Report no_mass =
      gap::diagnose(runs, sim::pooled_start(runs), gap::calibrated_options(gap::Condition::Ground));
  for (const auto& e : no_mass.effects)
    for (const auto& [name, v] : e.params) EXPECT_NE(name, "cg_height_over_wheelbase");
}

TEST(GapReferee, RollerVsRoadNamesTheTransferEffect) {
  // Bench vs bench: the roller's friction differs from the road's (mu_ratio = road / roller);
  // load transfer on the road (dFz/Fz 0.03 per m/s^2 through D). Each is named first, with its
  // magnitude within 25 %, and closes the gap.
  for (const auto& [inj, seed] :
       {std::pair{sim::Injection{"roller_friction", 1.3, gap::Condition::RollerToRoad}, 3},
        std::pair{sim::Injection{"load_transfer", 0.03, gap::Condition::RollerToRoad}, 5}}) {
    const auto t = sim::run_trial(inj, static_cast<std::uint64_t>(seed),
                                  gap::calibrated_options(inj.condition));
    ASSERT_FALSE(t.verdict.empty()) << inj.effect;
    EXPECT_EQ(t.verdict.front(), inj.effect);
    EXPECT_NEAR(t.estimate, inj.magnitude, 0.25 * inj.magnitude) << inj.effect;
    EXPECT_LT(t.gap_after_n, 0.02 * t.gap_before_n) << inj.effect;
    EXPECT_LT(t.gap_after_n, 1.5 * t.noise_n) << inj.effect;
  }
  // A cradle cap on the roller (3 000 N, below the tyre's 3 976 N peak): every roller run runs
  // away at the cap while its force still rises with slip. The verdict names it, with the cap,
  // and the road up to the cap is within the noise of the roller curve.
  const sim::Injection cap{"cradle_cap", 3000.0, gap::Condition::RollerToRoad};
  const auto c = sim::run_trial(cap, 5, gap::calibrated_options(cap.condition));
  ASSERT_FALSE(c.verdict.empty());
  EXPECT_EQ(c.verdict.front(), "cradle_cap");
  EXPECT_NEAR(c.estimate, 3000.0, 0.02 * 3000.0);
  EXPECT_LT(c.gap_after_n, 1.5 * c.noise_n);
  EXPECT_LT(c.gap_after_n, c.gap_before_n);
  // Roller and road with the same tyre and no transfer effect: none.
  const auto null = sim::run_trial({"none", 0.0, gap::Condition::RollerToRoad}, 4,
                                   gap::calibrated_options(gap::Condition::RollerToRoad));
  EXPECT_EQ(null.verdict, std::vector<std::string>{"none"});
}

TEST(GapReferee, TheFitQualityFactorSitsAboveTheLargestNullGap) {
  // A generator whose null sets leave a gap of up to 1.61x the floor (B's roller) gets a factor
  // 10 % above it; one whose nulls sit at the floor keeps the default 1.5.
  sim::GateCalibration g;
  g.null_best_gain = {0.01, 0.05};
  g.null_best_delta_bic = {-3.0, -20.0};
  g.null_points = {20.0, 400.0};  // -0.15 and -0.05 per point
  g.null_gap_over_floor = {1.02, 1.61};
  sim::set_gates(g);
  EXPECT_NEAR(g.options.noise_factor, 1.1 * 1.61, 1e-12);
  EXPECT_NEAR(g.options.gate_gain, 0.10, 1e-12);  // 1.5 x 0.05 is below the floor 0.10
  // The margin is per point, set by the small set's drop: 1.5 x 0.15. The floor stays.
  EXPECT_NEAR(g.options.bic_margin_per_point, 0.225, 1e-12);
  EXPECT_NEAR(g.options.bic_margin, gap::Options{}.bic_margin, 1e-12);
  sim::GateCalibration clean;
  clean.null_best_gain = {0.01};
  clean.null_best_delta_bic = {-1.0};
  clean.null_gap_over_floor = {1.1};
  sim::set_gates(clean);
  EXPECT_EQ(clean.options.noise_factor, gap::Options{}.noise_factor);
}

TEST(GapReferee, ShippedGatesSitAboveEveryNullScoreAndDrawsCoverNone) {
  for (auto c : {gap::Condition::Roller, gap::Condition::Ground, gap::Condition::RollerToRoad}) {
    const auto g = sim::calibrate_gates(c, 2, 1'000'000, gap::Options{});
    const gap::Options shipped = gap::calibrated_options(c);
    ASSERT_EQ(g.null_best_gain.size(), 2u);
    for (double x : g.null_best_gain) EXPECT_GT(shipped.gate_gain, x) << gap::to_string(c);
    for (double x : g.null_best_delta_bic)
      EXPECT_LT(-shipped.bic_margin, x) << gap::to_string(c);  // not accepted
    ASSERT_EQ(g.null_gap_over_floor.size(), 2u);  // the shipped fit-quality factor holds them
    for (double x : g.null_gap_over_floor) EXPECT_GT(shipped.noise_factor, x) << gap::to_string(c);
  }
  Rng rng(5);
  int none = 0;
  for (int i = 0; i < 400; ++i) none += sim::draw_injection(rng, 0.3).effect == "none";
  EXPECT_NEAR(none / 400.0, 0.3, 0.07);
}

TEST(GapReferee, NullSaysNoneAndAMisspecifiedTyreInventsNoEffect) {
  const gap::Options o = gap::calibrated_options(gap::Condition::Roller);
  const auto null = sim::run_trial(sim::Injection{}, 11, o);
  EXPECT_EQ(null.verdict, std::vector<std::string>{"none"});
  EXPECT_LT(null.gap_before_n, 1.5 * null.noise_n);
  // A Burckhardt friction curve is not a Magic Formula: none or unexplained, never an effect.
  const auto mis = sim::run_trial({"misspecified", 0.0}, 12, o);
  ASSERT_FALSE(mis.verdict.empty());
  EXPECT_TRUE(mis.correct()) << mis.verdict.front();
  EXPECT_EQ(mis.verdict.front(), "unexplained");
}

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
