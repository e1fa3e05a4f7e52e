// A fifth wheel's once-per-revolution ripple read from its own speed (core/gap/reference_ripple),
// and what it does for load transfer on generator B's ground runs (issue 10).
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>

#include "core/gap/internal.hpp"
#include "sim/referee.hpp"
#include "sim/second/generator.hpp"

using namespace brakefit;

namespace {

/// A vehicle slowing from v0 with a deceleration ramping up at jerk_mps3, read by a fifth wheel
/// of 0.2 m whose speed carries a ripple of amplitude `ripple` (phase 0.7 rad) and is quantised
/// to step_mps; 1 kHz.
struct Stop {
  std::vector<double> t_s, v_true, v_read;
};
Stop stop(double v0_mps, double span_s, double ripple, double step_mps) {
  Stop s;
  double angle = 0, v = v0_mps;
  for (double t = 0; t <= span_s; t += 1e-3) {
    const double decel = std::min(25.0 * t, 9.0);
    s.t_s.push_back(t);
    s.v_true.push_back(v);
    const double read = v * (1 + ripple * std::sin(angle + 0.7));
    s.v_read.push_back(step_mps > 0 ? step_mps * std::round(read / step_mps) : read);
    angle += v * 1e-3 / 0.2;
    v -= decel * 1e-3;
  }
  return s;
}

}  // namespace

TEST(ReferenceRipple, AFifthWheelsRippleIsReadFromItsOwnSpeed) {
  for (const double v0 : {13.9, 19.4}) {
    const Stop s = stop(v0, 0.6, 4e-4, 0.0);
    const auto r = gap::fifth_wheel_ripple(s.t_s, s.v_read, 0.2);
    ASSERT_TRUE(r.has_value()) << v0;
    ASSERT_TRUE(r->found) << v0;
    EXPECT_NEAR(r->amplitude, 4e-4, 0.4e-4) << v0;  // 7 % off at the deceleration's kink
    double worst = 0;  // what is left of a ripple of v0 x 4e-4 (5.6-7.8 mm/s)
    for (std::size_t i = 0; i < s.t_s.size(); ++i)
      worst = std::max(worst, std::abs(r->v_mps[i] - s.v_true[i]));
    EXPECT_LT(worst, 0.15 * 4e-4 * v0) << v0;
  }
}

TEST(ReferenceRipple, NoRippleIsFoundInASmoothOrShortStop) {
  // A vehicle slowing smoothly, read through 1 mm/s steps: no ripple.
  for (const double v0 : {8.3, 13.9, 19.4}) {
    const Stop s = stop(v0, 0.6, 0.0, 1e-3);
    const auto r = gap::fifth_wheel_ripple(s.t_s, s.v_read, 0.2);
    ASSERT_TRUE(r.has_value()) << v0;
    // A deceleration that stops rising mid-run (13.9 m/s) is read as a ripple of 3.4e-5: the
    // spline's misfit at the kink, under a tenth of the ripples generator B draws.
    EXPECT_TRUE(!r->found || r->amplitude < 5e-5) << v0 << ": amplitude " << r->amplitude;
  }
  // Under 2.5 revolutions the speed cannot tell a ripple from its trend: not looked for.
  const Stop s = stop(8.3, 0.2, 4e-4, 0.0);
  EXPECT_FALSE(gap::fifth_wheel_ripple(s.t_s, s.v_read, 0.2).has_value());
}

TEST(ReferenceRipple, TheSlipNoiseIsMeasuredAgainWithTheRippleOut) {
  // A fifth wheel at 50 km/h (0.2 m: 11 Hz) with a ripple of 3e-4, and white slip noise of 2e-4
  // at 500 Hz. The ripple passes the narrow smoother and not all of the wide one: measured on the
  // slip as conditioned, it is counted as noise. Once it is taken out of the slip, it is taken out
  // of what the noise was measured on too, and the noise is that of the slip the fit sees.
  constexpr int kHalfWindow = 10;
  constexpr double kSlip = 0.05, kSpeedMps = 13.9, kAmp = 3e-4, kPhase = 0.7;
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0.0, 2e-4);
  gap::Run r;
  std::vector<double> noise_only;
  for (int i = 0; i < 750; ++i) {
    const double t = i * 2e-3, ref_angle = kSpeedMps * t / 0.2;
    const double n = noise(rng);
    noise_only.push_back(kSlip + n);
    r.t_s.push_back(t);
    r.v_ref_mps.push_back(kSpeedMps);
    r.ref_angle_rad.push_back(ref_angle);
    r.wheel_angle_rad.push_back(kSpeedMps * (1 - kSlip) * t / 0.3);
    // Measured slip: s + (1 - s) eps_ref.
    r.slip.push_back(kSlip + n + (1 - kSlip) * kAmp * std::cos(ref_angle - kPhase));
    r.wheel_accel_mps2.push_back(0.0);
    r.ref_decel_mps2.push_back(0.0);
  }
  const double with_ripple = gap::smoothed_noise_sd(r.slip, kHalfWindow).value();
  const double without = gap::smoothed_noise_sd(noise_only, kHalfWindow).value();
  ASSERT_GT(with_ripple, 1.5 * without);  // the ripple inflates the measured noise
  r.slip_sd.assign(r.slip.size(), with_ripple);
  r.slip_noise = std::make_shared<const gap::Run::NoiseProbe>(
      gap::Run::NoiseProbe{kHalfWindow, r.slip, r.wheel_angle_rad, r.ref_angle_rad, with_ripple});
  gap::take_out_reference_ripple(r, kAmp * std::cos(kPhase), kAmp * std::sin(kPhase));
  EXPECT_NEAR(r.slip_sd.front(), without, 0.02 * without);
  EXPECT_NEAR(r.slip_sd.back(), without, 0.02 * without);
  ASSERT_TRUE(r.slip_noise);
  EXPECT_NEAR(r.slip_noise->sd, without, 0.02 * without);  // later estimates start from it
  // A run whose noise was not measured (no probe) keeps what it has.
  gap::Run bare = r;
  bare.slip_noise.reset();
  bare.slip_sd.assign(bare.slip.size(), 1e-3);
  gap::take_out_reference_ripple(bare, kAmp, 0.0);
  EXPECT_DOUBLE_EQ(bare.slip_sd.front(), 1e-3);
}

TEST(ReferenceRipple, LoadTransferBehindTheBodysPitchOnRunsWithARipplingFifthWheelIsNamed) {
  // Generator B's ground runs: the other brakes work, the load follows MF 6.1's laws about 0.1 s
  // behind the deceleration (the body's pitch), and the fifth wheel ripples (seed 1: 4.3e-4).
  // The ripple: read from the force residual, it took a third of load transfer's bend and its
  // derivative (0.6 m/s^2 at 70 km/h) was read as load (seed 1 said unexplained). It is read
  // from the fifth wheel's own speed, and the 30 km/h run (under 2.5 revolutions) takes the
  // others' amplitude, tested against what a ripple can explain beyond the spline's trend there,
  // not its whole variance (which left it in that run's slip noise: seed 1 said `none`).
  // The pitch: a candidate driven by the deceleration itself left most of such a set's gap
  // (generator C's load-transfer sets said `unexplained`); with the lag as its parameter the
  // load is named and the lag read back. Measured: lag 0.081, 0.095, 0.037 s; q 0.042 for
  // 0.0445, 0.047 for 0.0535, 0.049 for 0.0396.
  double lag_sum = 0;
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    sim2::SetDraw set = sim2::draw_set(can::BenchKind::Ground, "load_transfer", 0.0, seed);
    std::vector<gap::Run> runs;
    for (auto& run : set.runs) {
      run.pitch_lag_s = 0.1;
      run.pitch_hz = 0;  // a lag, not the mode half the vehicles draw
      sim::append_event_csv_runs(runs, sim2::simulate_event_csv(run), "b");
    }
    const gap::Report rep = gap::diagnose(runs, sim::pooled_start(runs),
                                          gap::calibrated_options(gap::Condition::Ground));
    ASSERT_FALSE(rep.verdict.empty());
    bool read = false, placed = false;
    for (const auto& n : rep.notes) {
      read |= n.find("read from its own speed") != std::string::npos;
      placed |= n.find("1 of 1 shorter runs took that amplitude") != std::string::npos;
    }
    EXPECT_TRUE(read) << "seed " << seed;
    EXPECT_TRUE(placed) << "seed " << seed;
    EXPECT_EQ(rep.verdict.front(), "load_transfer") << "seed " << seed;
    bool named = false;
    for (const auto& e : rep.effects) {
      if (e.effect != gap::Effect::LoadTransfer || !e.accepted) continue;
      named = true;
      for (const auto& [name, v] : e.params) {
        if (name == "pitch_lag_s") {
          EXPECT_GT(v, 0.02) << "seed " << seed;
          EXPECT_LT(v, 0.2) << "seed " << seed;
          lag_sum += v;
        }
        if (name == "dfz_per_decel_s2_per_m") {
          EXPECT_NEAR(v, set.magnitude, 0.25 * set.magnitude) << "seed " << seed;
        }
      }
    }
    EXPECT_TRUE(named) << "seed " << seed;
  }
  EXPECT_NEAR(lag_sum / 3, 0.1, 0.04);
}

TEST(ReferenceRipple, AHeavyWheelsSlowRunMisreadingItsOwnAmplitudeTakesTheOthers) {
  // Generator B's ground, a 2.69 kg m^2 wheel (seed 57005): the 30 km/h run turns the fifth
  // wheel 2.5 times, and its own speed read a ripple of 5.5e-4 beside 3.4e-4 and 3.3e-4 over the
  // others' 6 and 10 revolutions. Its remainder against the tyre's slope (15 N) was left in that
  // run: 6.4 N held out after the inertia. At the others' amplitude, its phase placed: 4.1 N.
  auto set = sim2::draw_set(can::BenchKind::Ground, "wheel_inertia", 2.6876665591931785, 57005);
  std::vector<gap::Run> runs;
  for (auto& run : set.runs) sim::append_event_csv_runs(runs, sim2::simulate_event_csv(run), "b");
  const gap::Report rep =
      gap::diagnose(runs, sim::pooled_start(runs), gap::calibrated_options(gap::Condition::Ground));
  bool took = false;
  for (const auto& n : rep.notes)
    took |= n.find("1 run whose own amplitude, read over fewer than 4 revolutions") !=
            std::string::npos;
  EXPECT_TRUE(took);
  ASSERT_FALSE(rep.verdict.empty());
  EXPECT_EQ(rep.verdict.front(), "wheel_inertia");
  EXPECT_LT(rep.gap_after_rmse_n, 5.0);
}
