// A bench's measurement model (issue 36): written and read back, refused with the key named, and
// undone on an event's points so that what is left is the tyre's curve.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "core/gap/bench_model.hpp"
#include "core/gap/gap.hpp"
#include "core/magic_formula.hpp"

using namespace brakefit;

namespace {

/// A roller run at 1.4 m/s: slip rising to 15 % over 1.5 s, the wheel slowing with it.
gap::Run synthetic_run() {
  gap::Run r;
  r.wheel_radius_m = 0.3;
  r.brake_gain_n_per_bar = 60.0;
  const std::size_t n = 600;
  for (std::size_t i = 0; i < n; ++i) {
    const double t = 1.5 * static_cast<double>(i) / (n - 1);
    const double slip = 0.1 * t * t / 1.5 + 0.05 * t / 1.5;
    r.t_s.push_back(t);
    r.slip.push_back(slip);
    r.v_ref_mps.push_back(1.4);
    // d/dt of 1.4 (1 - slip)
    r.wheel_accel_mps2.push_back(-1.4 * (0.2 * t / 1.5 + 0.05 / 1.5));
    r.ref_decel_mps2.push_back(0.0);
    r.pressure_rate_bar_per_s.push_back(20.0);
  }
  r.force_n.assign(n, 0.0);
  r.initial_slip_rate_per_s = 0.05 / 1.5;
  return r;
}

gap::BenchModel model_of(const std::vector<gap::Effect>& effects,
                         const std::vector<double>& values) {
  gap::BenchModel m;
  m.condition = "roller";
  for (std::size_t i = 0; i < effects.size(); ++i)
    m.effects.push_back({effects[i], values[i], NAN, {}, {}});
  return m;
}

}  // namespace

TEST(BenchModel, WrittenAndReadBack) {
  gap::BenchModel m =
      model_of({gap::Effect::RelaxationLength, gap::Effect::BrakeThreshold}, {0.209, 0.443});
  m.effects[0].stderr_ = 0.0002;
  m.not_held = {"load_transfer"};
  m.model_hash = "sha256:abc";
  m.date = "2026-11-26T10:00:00Z";
  m.runs = {"a.log", "b.log"};
  const std::string text = gap::format_bench_model(m);
  EXPECT_NE(text.find("sha256:abc"), std::string::npos);
  EXPECT_NE(text.find("a.log"), std::string::npos);
  const gap::BenchModel back = gap::parse_bench_model(text, "m.toml");
  EXPECT_EQ(back.condition, "roller");
  ASSERT_EQ(back.effects.size(), 2u);
  EXPECT_EQ(back.effects[0].effect, gap::Effect::RelaxationLength);
  EXPECT_DOUBLE_EQ(back.effects[0].value, 0.209);
  EXPECT_DOUBLE_EQ(back.effects[0].stderr_, 0.0002);
  EXPECT_EQ(back.effects[1].effect, gap::Effect::BrakeThreshold);
  // A standard error the fit could not give is said so, not written as a number.
  EXPECT_TRUE(std::isnan(back.effects[1].stderr_));
  EXPECT_NE(text.find("# standard error not known"), std::string::npos);
  EXPECT_EQ(back.not_held, std::vector<std::string>{"load_transfer"});
}

TEST(BenchModel, BadFilesNameTheKey) {
  auto message = [](const std::string& text) {
    try {
      gap::parse_bench_model(text, "m.toml");
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string head =
      "schema = \"brakefit.bench_model\"\nversion = 1\ncondition = \"roller\"\n";
  EXPECT_NE(message("schema = \"other\"\nversion = 1\n").find("'schema'"), std::string::npos);
  EXPECT_NE(message(head + "[effects.load_transfer]\nq = 1\n").find("'effects.load_transfer'"),
            std::string::npos);
  EXPECT_NE(
      message(head + "[effects.brake_threshold]\np0 = 1\n").find("effects.brake_threshold.p0"),
      std::string::npos);
  EXPECT_NE(message(head + "[effects.brake_threshold]\np0_bar = -3\n").find("outside"),
            std::string::npos);
  EXPECT_NE(message(head + "[effects.wheel_inertia]\n").find("inertia_kgm2"), std::string::npos);
  EXPECT_NE(message("schema = \"brakefit.bench_model\"\nversion = 1\ncondition = \"moon\"\n")
                .find("'condition'"),
            std::string::npos);
  EXPECT_EQ(message(head), "no error");
}

TEST(BenchModel, UndoingTheEffectsLeavesTheTyresCurve) {
  // The instrument's force made by predict() from a known tyre and known effects: undone with the
  // same magnitudes, the points lie on the tyre's curve.
  const MfParams tyre{15.0, 1.58, 3400.0, 0.1, 0, 0};
  const std::vector<gap::Effect> effects{gap::Effect::WheelInertia, gap::Effect::BrakeThreshold,
                                         gap::Effect::SlipOffset, gap::Effect::TimeOffset};
  const std::vector<double> values{0.8, 1.5, 0.004, 0.02};
  gap::Run r = synthetic_run();
  std::vector<double> p{tyre.B, tyre.C, tyre.D, tyre.E};
  p.insert(p.end(), values.begin(), values.end());
  // The threshold's term reads the measured force: iterate to the fixed point.
  for (int k = 0; k < 20; ++k) r.force_n = gap::predict(r, p, effects);
  const gap::TyrePoints pts = gap::tyre_points(r, model_of(effects, values));
  ASSERT_GT(pts.curve.size(), 500u);
  double worst = 0, raw_worst = 0;
  for (std::size_t i = 0; i < pts.curve.size(); ++i) {
    if (pts.curve.slip_ratio[i] < 0) continue;  // before the ramp reached the tyre
    worst =
        std::max(worst, std::abs(pts.curve.force_n[i] - mf_force_n(tyre, pts.curve.slip_ratio[i])));
  }
  for (std::size_t i = 0; i < r.t_s.size(); ++i)
    raw_worst = std::max(raw_worst, std::abs(r.force_n[i] - mf_force_n(tyre, r.slip[i])));
  EXPECT_LT(worst, 0.005 * tyre.D) << "raw points were " << raw_worst << " N off";
  EXPECT_GT(raw_worst, 0.05 * tyre.D);  // the effects were there to undo
}

TEST(BenchModel, TheRelaxationLagIsUndone) {
  const MfParams tyre{15.0, 1.58, 3400.0, 0.1, 0, 0};
  gap::Run r = synthetic_run();
  const std::vector<gap::Effect> effects{gap::Effect::RelaxationLength};
  r.initial_force_n = 0.0;
  r.force_n = gap::predict(r, {tyre.B, tyre.C, tyre.D, tyre.E, 0.25}, effects);
  const gap::TyrePoints pts = gap::tyre_points(r, model_of(effects, {0.25}));
  double worst = 0;
  for (std::size_t i = 0; i < pts.curve.size(); ++i)
    worst =
        std::max(worst, std::abs(pts.curve.force_n[i] - mf_force_n(tyre, pts.curve.slip_ratio[i])));
  EXPECT_LT(worst, 0.005 * tyre.D);
}

TEST(BenchModel, ALoadTransferIsWrittenWithItsRatioAndLagAndRefusedOnARoller) {
  gap::BenchModel m = model_of({gap::Effect::LoadTransfer}, {0.0337});
  m.condition = "ground";
  m.effects[0].more = {1.4, 0.08, 0.016};
  m.effects[0].origin = "declared from the vehicle";
  const std::string text = gap::format_bench_model(m);
  EXPECT_NE(text.find("# declared from the vehicle\n[effects.load_transfer]"), std::string::npos)
      << text;
  const gap::BenchModel back = gap::parse_bench_model(text, "m.toml");
  ASSERT_EQ(back.effects.size(), 1u);
  EXPECT_DOUBLE_EQ(back.effects[0].value, 0.0337);
  EXPECT_EQ(back.effects[0].more, (std::vector<double>{1.4, 0.08, 0.016}));
  EXPECT_NE(text.find("pitch_mode_s2 = 0.016"), std::string::npos) << text;
  // Written by hand without its ratio, lag and mode: the published ratio, no lag, no mode.
  const gap::BenchModel bare = gap::parse_bench_model(
      "schema = \"brakefit.bench_model\"\nversion = 1\ncondition = \"ground\"\n"
      "[effects.load_transfer]\ndfz_per_decel_s2_per_m = 0.03\n",
      "m.toml");
  ASSERT_EQ(bare.effects.size(), 1u);
  EXPECT_EQ(bare.effects[0].more, (std::vector<double>{1.25, 0.0, 0.0}));
  std::string roller = text;
  roller.replace(roller.find("\"ground\""), 8, "\"roller\"");
  try {
    gap::parse_bench_model(roller, "m.toml");
    ADD_FAILURE() << "a roller model with a load transfer was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("'effects.load_transfer'"), std::string::npos) << e.what();
  }
}

TEST(BenchModel, TheDeclaredLoadTransferFollowsTheVehiclesGeometry) {
  // m h / (2 L Fz) of the wheel's load per m/s^2: 1300 kg, 0.55 m, 2.6 m, 3800 N -> 0.0362.
  const gap::BenchEffect front = gap::declared_load_transfer(1300, 0.55, 2.6, 3800, true);
  const gap::BenchEffect rear = gap::declared_load_transfer(1300, 0.55, 2.6, 3800, false);
  EXPECT_EQ(front.effect, gap::Effect::LoadTransfer);
  EXPECT_NEAR(front.value, 0.93 * 1300 * 0.55 / (2 * 2.6 * 3800), 1e-9);
  EXPECT_DOUBLE_EQ(rear.value, -front.value);  // the rear wheels unload
  EXPECT_EQ(front.more, (std::vector<double>{1.25, 0.0, 0.0}));
  EXPECT_NE(front.origin.find("1300 kg"), std::string::npos);
}

TEST(BenchModel, ADeclaredLoadTransferIsHeldInTheFitsThroughASmoothedDeceleration) {
  // gap --vehicle-mass --cg-height --wheelbase holds the declared law in every fit
  // (Run::declared_load_per_decel_s2_per_m): at a steady deceleration the force is the load
  // transfer effect's with the same q and ratio; the fifth wheel's derivative noise is read
  // through a +-20 ms centred mean, so it reaches the force a tenth as strongly.
  const std::vector<double> tyre{15.0, 1.58, 3400.0, 0.1};
  gap::Run steady = synthetic_run();
  steady.bench = can::BenchKind::Ground;
  steady.load_laws.e_per_peak_scale = 0.0;  // the free effect's E stays; its laws' E below
  steady.ref_decel_mps2.assign(steady.t_s.size(), 6.0);
  gap::Run noisy = steady;
  for (std::size_t i = 0; i < noisy.t_s.size(); ++i)
    noisy.ref_decel_mps2[i] += (i % 2 ? 0.5 : -0.5);
  const std::vector<double> with_lt{tyre[0], tyre[1], tyre[2], tyre[3], 0.034, 1.25, 0.0, 0.0};
  const auto effect = gap::predict(steady, with_lt, {gap::Effect::LoadTransfer});
  const auto effect_noisy = gap::predict(noisy, with_lt, {gap::Effect::LoadTransfer});
  for (gap::Run* r : {&steady, &noisy}) {
    r->declared_load_per_decel_s2_per_m = 0.034;
    r->declared_kx_load_ratio = 1.25;
  }
  const auto held = gap::predict(steady, tyre, {});
  const auto held_noisy = gap::predict(noisy, tyre, {});
  const auto bare = gap::predict(synthetic_run(), tyre, {});
  double off = 0, noise_effect = 0, noise_held = 0, moved = 0;
  for (std::size_t i = 20; i + 20 < held.size(); ++i) {  // the mean's edges aside
    off = std::max(off, std::abs(held[i] - effect[i]));
    noise_effect = std::max(noise_effect, std::abs(effect_noisy[i] - effect[i]));
    noise_held = std::max(noise_held, std::abs(held_noisy[i] - held[i]));
    moved = std::max(moved, std::abs(held[i] - bare[i]));
  }
  EXPECT_LT(off, 1e-6 * tyre[2]);
  EXPECT_GT(moved, 0.1 * tyre[2]);  // a fifth more load at 6 m/s^2
  EXPECT_GT(noise_effect, 10.0);
  EXPECT_LT(noise_held, 0.1 * noise_effect);

  // At the held load laws (a tyre's file's, else the published tyres') E changes with the load
  // too: the declared load is the measured load transfer's at the same q, not the one with E
  // fixed.
  steady.load_laws = tyre::LoadLaws{0.9, 1.4, 0.3};
  steady.declared_kx_load_ratio = 1.4;
  const auto held_at_laws = gap::predict(steady, tyre, {});
  steady.load_laws.e_per_peak_scale = 0.0;
  const auto held_e_fixed = gap::predict(steady, tyre, {});
  steady.load_laws.e_per_peak_scale = 0.3;
  const std::vector<double> measured_q{tyre[0], tyre[1], tyre[2], tyre[3], 0.034, 0.0, 0.0};
  gap::Run undeclared = steady;
  undeclared.declared_load_per_decel_s2_per_m = 0.0;
  const auto measured = gap::predict(undeclared, measured_q, {gap::Effect::LoadTransferMeasured});
  double off_laws = 0, e_moved = 0;
  for (std::size_t i = 20; i + 20 < held.size(); ++i) {
    off_laws = std::max(off_laws, std::abs(held_at_laws[i] - measured[i]));
    e_moved = std::max(e_moved, std::abs(held_at_laws[i] - held_e_fixed[i]));
  }
  EXPECT_LT(off_laws, 1e-6 * tyre[2]);
  EXPECT_GT(e_moved, 1e-3 * tyre[2]);  // E by 0.3 x 0.2 of D's change
}

TEST(BenchModel, AGroundWheelsLoadTransferIsUndoneToItsStaticLoad) {
  // A braking car: the deceleration rises with the force, the front wheel's load with it through
  // the body's pitch mode (1.3 Hz). predict() makes the force at the moving load; undone, the
  // points lie on the tyre's curve at the static load.
  const MfParams tyre{15.0, 1.58, 3400.0, 0.1, 0, 0};
  gap::Run r = synthetic_run();
  r.bench = can::BenchKind::Ground;
  for (std::size_t i = 0; i < r.t_s.size(); ++i) {
    r.v_ref_mps[i] = 11.0 - 4.0 * r.t_s[i];
    r.ref_decel_mps2[i] = 9.0 * std::min(1.0, r.t_s[i] / 0.8);
  }
  const std::vector<gap::Effect> effects{gap::Effect::LoadTransfer};
  const std::vector<double> lt{0.034, 1.3, 0.06, 0.015};
  r.initial_force_n = 0.0;
  r.force_n =
      gap::predict(r, {tyre.B, tyre.C, tyre.D, tyre.E, lt[0], lt[1], lt[2], lt[3]}, effects);
  gap::BenchModel m = model_of(effects, {lt[0]});
  m.condition = "ground";
  m.effects[0].more = {lt[1], lt[2], lt[3]};
  const gap::TyrePoints pts = gap::tyre_points(r, m);
  double worst = 0, raw_worst = 0;
  for (std::size_t i = 0; i < pts.curve.size(); ++i) {
    worst =
        std::max(worst, std::abs(pts.curve.force_n[i] - mf_force_n(tyre, pts.curve.slip_ratio[i])));
    raw_worst = std::max(raw_worst, std::abs(r.force_n[i] - mf_force_n(tyre, r.slip[i])));
  }
  EXPECT_LT(worst, 0.005 * tyre.D) << "raw points were " << raw_worst << " N off";
  EXPECT_GT(raw_worst, 0.2 * tyre.D);  // a third more load at 9 m/s^2
}

TEST(BenchModel, FromAReportHoldsTheInstrumentsEffectsOnly) {
  gap::Report rep;
  rep.accepted = {gap::Effect::TyreShift, gap::Effect::RelaxationLength, gap::Effect::LoadTransfer,
                  gap::Effect::WheelInertia};
  // B C D E, tyre shift, sigma, load transfer (q, ratio, pitch lag, pitch mode), inertia
  rep.after.params = {15, 1.5, 3400, 0.1, 1e-4, 0.2, 0.03, 1.2, 0.1, 0.02, 0.9};
  rep.after.stderr_ = {0, 0, 0, 0, 0, 0.01, 0, 0, 0, 0, 0.05};
  // On a roller a load transfer is not the instrument's and stays in the curve, said so.
  const gap::BenchModel m = gap::bench_model_from(rep, gap::Condition::Roller);
  EXPECT_EQ(m.condition, "roller");
  ASSERT_EQ(m.effects.size(), 2u);
  EXPECT_EQ(m.effects[0].effect, gap::Effect::RelaxationLength);
  EXPECT_DOUBLE_EQ(m.effects[0].value, 0.2);
  EXPECT_DOUBLE_EQ(m.effects[0].stderr_, 0.01);
  EXPECT_EQ(m.effects[1].effect, gap::Effect::WheelInertia);
  EXPECT_DOUBLE_EQ(m.effects[1].value, 0.9);
  EXPECT_EQ(m.not_held, std::vector<std::string>{"load_transfer"});
  // Where the runs disagree more than the fit's own error says (the folds' spread), the standard
  // error is the spread; where less, the fit's.
  gap::Report spread = rep;
  spread.after_spread = {0, 0, 0, 0, 0, 0.04, 0, 0, 0, 0, 0.01};
  const gap::BenchModel s = gap::bench_model_from(spread, gap::Condition::Roller);
  EXPECT_DOUBLE_EQ(s.effects[0].stderr_, 0.04);
  EXPECT_DOUBLE_EQ(s.effects[1].stderr_, 0.05);
  // On the ground it is the vehicle's, undone with its ratio and lag: the tyre at its static load.
  const gap::BenchModel g = gap::bench_model_from(rep, gap::Condition::Ground);
  ASSERT_EQ(g.effects.size(), 3u);
  EXPECT_EQ(g.effects[1].effect, gap::Effect::LoadTransfer);
  EXPECT_DOUBLE_EQ(g.effects[1].value, 0.03);
  EXPECT_EQ(g.effects[1].more, (std::vector<double>{1.2, 0.1, 0.02}));
  EXPECT_TRUE(g.not_held.empty());
  // Where the report measured it (the stiffness ratio held at the published tyres'), that
  // magnitude is held, not the free fit's.
  gap::EffectScore lt;
  lt.effect = gap::Effect::LoadTransfer;
  lt.accepted = true;
  lt.params = {{"dfz_per_decel_s2_per_m", 0.006},
               {"kx_load_ratio", 0.38},
               {"pitch_lag_s", 0.02},
               {"pitch_mode_s2", 0.015},
               {"dfz_per_decel_free_ratio_s2_per_m", 0.03}};
  rep.effects = {lt};
  const gap::BenchModel measured = gap::bench_model_from(rep, gap::Condition::Ground);
  ASSERT_EQ(measured.effects.size(), 3u);
  EXPECT_DOUBLE_EQ(measured.effects[1].value, 0.006);
  EXPECT_EQ(measured.effects[1].more, (std::vector<double>{1.25, 0.02, 0.015}));
}

TEST(BenchModel, ADeclaredPressureFilterIsUndone) {
  // The exporting software's first-order filter on the pressure channel (pressure_filter_s in
  // the event CSV): the channel lags the line by tau, tens of newtons on a fast ramp.
  const MfParams tyre{15.0, 1.58, 3400.0, 0.1, 0, 0};
  gap::Run r = synthetic_run();
  r.pressure_filter_s = 0.015;
  r.initial_force_n = 0.0;
  r.force_n = gap::predict(r, {tyre.B, tyre.C, tyre.D, tyre.E}, {});
  const std::size_t n = r.t_s.size();
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t a = i == 0 ? 0 : i - 1, b = i + 1 == n ? i : i + 1;
    r.pressure_rate_bar_per_s[i] =
        (r.force_n[b] - r.force_n[a]) / (r.t_s[b] - r.t_s[a]) / r.brake_gain_n_per_bar;
  }
  const gap::TyrePoints pts = gap::tyre_points(r, model_of({}, {}));
  double worst = 0, raw_worst = 0;
  for (std::size_t i = 10; i < n; ++i) {  // past the filter's start from rest
    worst =
        std::max(worst, std::abs(pts.curve.force_n[i] - mf_force_n(tyre, pts.curve.slip_ratio[i])));
    raw_worst = std::max(raw_worst, std::abs(r.force_n[i] - mf_force_n(tyre, r.slip[i])));
  }
  EXPECT_LT(worst, 0.005 * tyre.D) << "raw points were " << raw_worst << " N off";
  EXPECT_GT(raw_worst, 0.01 * tyre.D);
}
