// The MF 6.1 fit and its .tir file, checked against what it did not write: curves drawn from the
// second simulator's tyre files (sim/second/tyres, its own MF 6.1 code), and every written file
// read back by the second simulator's own .tir reader.
#include <gtest/gtest.h>

#include <fmt/format.h>
#include <cmath>

#include <random>

#include "core/tyre/mf61_fit.hpp"
#include "core/tyre/scaling.hpp"
#include "core/tyre/tir_writer.hpp"
#include "sim/second/generator.hpp"
#include "sim/second/tir.hpp"
#include "sim/second/tyre.hpp"

namespace {

using namespace brakefit;
using sim2::Mf61Longitudinal;

struct Drawn {
  std::vector<tyre::TyreCurve> curves;
  double peak_n = 0;
};

/// Curves of an MF 6.1 tyre at the given loads (times FNOMIN) and pressures (times NOMPRES),
/// slip 0..slip_max, noise_share of each curve's peak as Gaussian noise.
Drawn draw(const Mf61Longitudinal& t, const std::vector<double>& loads,
           const std::vector<double>& pressures, double slip_max, double noise_share, unsigned seed,
           double lmux = 1.0) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01;
  Drawn d;
  Mf61Longitudinal scaled = t;
  scaled.lmux = lmux;
  for (double l : loads)
    for (double p : pressures) {
      sim2::Contact c;
      c.fz_n = l * t.fnomin_n;
      c.pressure_pa = p * t.nompres_pa;
      tyre::TyreCurve tc;
      tc.source = fmt::format("{} Fz {:.1f} p {:.1f}", t.name, l, p);
      tc.op = {c.fz_n, c.pressure_pa, 5.0 / 3.6};
      const int n = 200;
      double peak = 0;
      for (int k = 1; k <= n; ++k) {
        const double s = slip_max * k / n;
        tc.curve.slip_ratio.push_back(s);
        tc.curve.force_n.push_back(sim2::mf61_braking_force_n(scaled, s, c));
        peak = std::max(peak, tc.curve.force_n.back());
      }
      for (auto& f : tc.curve.force_n) f += noise_share * peak * n01(rng);
      d.curves.push_back(std::move(tc));
    }
  return d;
}

/// RMS over slip 0..1 of (written file - truth), % of the truth's peak, at one load and pressure.
double rms_pct(const Mf61Longitudinal& truth, const Mf61Longitudinal& written, double fz_n,
               double pressure_pa) {
  sim2::Contact c;
  c.fz_n = fz_n;
  c.pressure_pa = pressure_pa;
  double ss = 0, peak = 0;
  const int n = 400;
  for (int k = 0; k <= n; ++k) {
    const double s = static_cast<double>(k) / n;
    const double a = sim2::mf61_braking_force_n(truth, s, c);
    const double b = sim2::mf61_braking_force_n(written, s, c);
    ss += (a - b) * (a - b);
    peak = std::max(peak, a);
  }
  return 100.0 * std::sqrt(ss / (n + 1)) / peak;
}

Mf61Longitudinal read_back(const std::string& text) {
  return sim2::mf61_from_tir(sim2::parse_tir(text, "written.tir"), "written");
}

TEST(TyreFit, EachShippedTyreFileIsRecoveredOverLoadsAndPressures) {
  const std::vector<double> loads{0.6, 1.0, 1.4}, pressures{1.0, 1.2};
  for (const auto& truth : sim2::tyre_library()) {
    SCOPED_TRACE(truth.name);
    const Drawn d = draw(truth, loads, pressures, 1.0, 0.01, 7);
    const tyre::Mf61FitResult fit = tyre::fit_mf61(d.curves);
    EXPECT_EQ(fit.loads, 3u);
    EXPECT_EQ(fit.pressures, 2u);
    const std::string tir = tyre::format_tir(fit, {"test", "", "", {"drawn"}, 0.3, truth.name});
    const Mf61Longitudinal written = read_back(tir);
    // What the file says is what the fit holds: the second simulator's reader and evaluator
    // reproduce the fit's own forces.
    for (const auto& tc : d.curves) {
      sim2::Contact c;
      c.fz_n = tc.op.fz_n;
      c.pressure_pa = tc.op.pressure_pa;
      double worst = 0;
      for (double s = 0; s <= 1.0; s += 0.01)
        worst = std::max(worst, std::abs(sim2::mf61_braking_force_n(written, s, c) -
                                         tyre::braking_force_n(fit.tyre, tc.op, s)));
      EXPECT_LT(worst, 1e-3 * tc.curve.peak_abs_force_n()) << tc.source;
    }
    double worst_fitted = 0, worst_between = 0;
    for (double p : pressures) {
      for (double l : loads)
        worst_fitted = std::max(worst_fitted,
                                rms_pct(truth, written, l * truth.fnomin_n, p * truth.nompres_pa));
      for (double l = 0.5; l <= 1.501; l += 0.1)
        worst_between = std::max(worst_between,
                                 rms_pct(truth, written, l * truth.fnomin_n, p * truth.nompres_pa));
    }
    EXPECT_LT(worst_fitted, 2.0);
    EXPECT_LT(worst_between, 4.0);
    std::printf("%s: RMS %% of peak, fitted loads %.2f, 0.5-1.5 Fz0 %.2f; %zu held\n",
                truth.name.c_str(), worst_fitted, worst_between, fit.held.size());
  }
}

TEST(TyreFit, OneLoadAndOnePressureHoldTheirLawsAndSaySo) {
  const auto& truth = sim2::tyre_library().front();
  const Drawn d = draw(truth, {1.0}, {1.0}, 1.0, 0.01, 3);
  const tyre::Mf61FitResult fit = tyre::fit_mf61(d.curves);
  for (tyre::Coef c : {tyre::Coef::PDX2, tyre::Coef::PKX2, tyre::Coef::PPX1, tyre::Coef::PPX3,
                       tyre::Coef::LMUV, tyre::Coef::PEX4})
    EXPECT_TRUE(fit.held_at(static_cast<std::size_t>(c)))
        << tyre::coef_name(static_cast<std::size_t>(c));
  EXPECT_FALSE(fit.held_at(static_cast<std::size_t>(tyre::Coef::PDX1)));
  const std::string tir = tyre::format_tir(fit, {"test", "", "", {}, NAN, ""});
  const std::size_t line = tir.find("\nPDX2 ");
  ASSERT_NE(line, std::string::npos);
  EXPECT_NE(tir.substr(line, tir.find('\n', line + 1) - line).find("$ held: one wheel load"),
            std::string::npos)
      << tir;
  // At the one load and pressure measured, the file still carries the curve.
  EXPECT_LT(rms_pct(truth, read_back(tir), truth.fnomin_n, truth.nompres_pa), 2.0);
}

TEST(TyreFit, ARollersSlipRangeNamesWhatItCannotIdentify) {
  // A roller switches off at 27 % slip: the tail beyond is unmeasured.
  const auto& truth = sim2::tyre_library().back();
  const Drawn d = draw(truth, {0.6, 1.0, 1.4}, {1.0}, 0.27, 0.01, 5);
  const tyre::Mf61FitResult fit = tyre::fit_mf61(d.curves);
  std::size_t statistical = 0;
  for (const auto& h : fit.held)
    if (h.reason.starts_with("not identified")) ++statistical;
  EXPECT_GE(statistical, 1u);
  // Over the range it measured, the file is still the tyre.
  double worst = 0;
  for (const auto& c : fit.curves) worst = std::max(worst, c.rms_pct_peak);
  EXPECT_LT(worst, 2.0);
  const std::string tir = tyre::format_tir(fit, {"test", "", "", {}, NAN, ""});
  EXPECT_NE(tir.find("not identified by these curves"), std::string::npos);
  EXPECT_NE(tir.find("KPUMIN                = -0.27"), std::string::npos) << tir;
}

TEST(TyreFit, ARigsFrictionScaleIsFoundAsLmux) {
  const auto& truth = sim2::tyre_library()[1];
  const Drawn road = draw(truth, {0.6, 1.0, 1.4}, {1.0}, 1.0, 0.01, 11);
  const Drawn rig = draw(truth, {0.6, 1.0, 1.4}, {1.0}, 1.0, 0.01, 12, 0.85);
  const tyre::Mf61FitResult fit = tyre::fit_mf61(road.curves);
  const tyre::ScalingFit s = tyre::fit_scalings(fit.tyre, rig.curves);
  EXPECT_NEAR(s.value[0], 0.85, 0.01);
  EXPECT_LT(s.stderr_[0], 0.01);
  EXPECT_LT(s.rms_pct_peak, 2.0);
  EXPECT_GT(s.unscaled_rms_pct_peak, 5.0);
  const std::string tir = tyre::format_tir(fit, {"test", "", "", {}, NAN, ""}, s);
  EXPECT_NEAR(read_back(tir).lmux, s.value[0], 1e-6);
}

TEST(TyreFit, TwoSpeedsIdentifyTheSlipSpeedDecay) {
  // MF 6.1's LMUV lowers friction with slip speed |kappa| V; at one speed it is the curve's shape,
  // at 5 and 40 km/h it is measured.
  const auto& truth = sim2::tyre_library()[1];
  const double lmuv = 1.5;
  std::mt19937_64 rng(21);
  std::normal_distribution<double> n01;
  std::vector<tyre::TyreCurve> curves;
  for (double l : {0.6, 1.0, 1.4})
    for (double v_kmh : {5.0, 40.0}) {
      tyre::TyreCurve tc;
      tc.source = fmt::format("Fz {} v {}", l, v_kmh);
      tc.op = {l * truth.fnomin_n, truth.nompres_pa, v_kmh / 3.6};
      for (int k = 1; k <= 200; ++k) {
        const double s = k / 200.0;
        sim2::Contact c;
        c.fz_n = tc.op.fz_n;
        c.pressure_pa = tc.op.pressure_pa;
        c.lmuv = lmuv;
        c.slip_speed_mps = s * tc.op.speed_mps;
        tc.curve.slip_ratio.push_back(s);
        tc.curve.force_n.push_back(sim2::mf61_braking_force_n(truth, s, c));
      }
      const double peak = tc.curve.peak_abs_force_n();
      for (auto& f : tc.curve.force_n) f += 0.01 * peak * n01(rng);
      curves.push_back(std::move(tc));
    }
  const tyre::Mf61FitResult fit = tyre::fit_mf61(curves);
  const auto i = static_cast<std::size_t>(tyre::Coef::LMUV);
  ASSERT_FALSE(fit.held_at(i));
  EXPECT_NEAR(fit.tyre.coef[i], lmuv, 0.15 * lmuv);
  EXPECT_EQ(fit.speeds, 2u);
}

TEST(TyreFit, BadCurvesAreRefusedNamingTheCurve) {
  tyre::TyreCurve tc;
  tc.source = "few.csv";
  tc.curve.slip_ratio = {0.1, 0.2};
  tc.curve.force_n = {100, 200};
  EXPECT_THROW(
      {
        try {
          tyre::fit_mf61({tc});
        } catch (const InputError& e) {
          EXPECT_NE(std::string(e.what()).find("few.csv"), std::string::npos);
          throw;
        }
      },
      InputError);
  EXPECT_THROW(tyre::fit_mf61({}), InputError);
}

}  // namespace
