// An MF 6.1 tyre's load laws (core/tyre/load_laws.hpp) checked against the curve itself: the peak,
// the slip stiffness and the curvature read off the formula's force at loads 0.1 % apart, for the
// published tyre files sim/second ships, read through the second simulator's own .tir reader.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "core/curve.hpp"
#include "core/tyre/load_laws.hpp"
#include "core/tyre/tir_numbers.hpp"
#include "sim/referee.hpp"
#include "sim/referee_internal.hpp"
#include "sim/second/tir.hpp"
#include "sim/second/tyre.hpp"

namespace {

using namespace brakefit;

std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

struct Read {
  double d_n, kx_n, e;
};

/// D, Kx and E as a person would read them off the braking curve: the peak, the slope at the
/// foot, and E solved from one point below the peak given B = Kx / (C D).
Read read_curve(const tyre::Mf61Tyre& t, double fz_n) {
  tyre::OperatingPoint op;
  op.fz_n = fz_n;
  op.pressure_pa = t.ref.nompres_pa;
  Read r{0, 0, 0};
  double peak_slip = 0;
  for (double s = 1e-4; s < 0.6; s += 1e-5) {
    const double f = tyre::braking_force_n(t, op, s);
    if (f > r.d_n) r.d_n = f, peak_slip = s;
  }
  const double h = 1e-7;
  r.kx_n = (tyre::braking_force_n(t, op, h) - tyre::braking_force_n(t, op, -h)) / (2 * h);
  const double c = t.coef[static_cast<std::size_t>(tyre::Coef::PCX1)];
  const double b = r.kx_n / (c * r.d_n), s = 0.5 * peak_slip, bk = b * s;
  const double inner = std::tan(std::asin(tyre::braking_force_n(t, op, s) / r.d_n) / c);
  r.e = (bk - inner) / (bk - std::atan(bk));
  return r;
}

/// The four car and van files whose laws the diagnosis holds where a tyre's own is not given.
constexpr const char* kPublishedTyres[] = {"car_185_65r15.tir", "car_225_50r17.tir",
                                           "tno_205_60r15.tir", "van_215_65r16c.tir"};

class LoadLaws : public ::testing::TestWithParam<const char*> {};

TEST_P(LoadLaws, FollowTheCurveReadAtNeighbouringLoads) {
  const std::string path = std::string(BRAKEFIT_SOURCE_DIR) + "/sim/second/tyres/" + GetParam();
  const tyre::Mf61Tyre t = tyre::tyre_from_tir(sim2::parse_tir(slurp(path), path).numbers, path);
  // The reading agrees with the second simulator's own reader of the file.
  const sim2::Mf61Longitudinal other =
      sim2::mf61_from_tir(sim2::parse_tir(slurp(path), path), path);
  auto coef = [&t](tyre::Coef k) { return t.coef[static_cast<std::size_t>(k)]; };
  EXPECT_EQ(t.ref.fnomin_n, other.fnomin_n);
  EXPECT_EQ(t.ref.lfzo, other.lfzo);
  EXPECT_EQ(coef(tyre::Coef::PDX2), other.pdx2);
  EXPECT_EQ(coef(tyre::Coef::PKX2), other.pkx2);
  EXPECT_EQ(coef(tyre::Coef::PKX3), other.pkx3);
  EXPECT_EQ(coef(tyre::Coef::PEX3), other.pex3);
  EXPECT_EQ(coef(tyre::Coef::PEX4), other.pex4);
  // The shifts (SHx, SVx) move the curve, not its load laws: read without them, E comes off one
  // point of the curve alone.
  tyre::Mf61Tyre bare = t;
  for (tyre::Coef k : {tyre::Coef::PHX1, tyre::Coef::PHX2, tyre::Coef::PVX1, tyre::Coef::PVX2})
    bare.coef[static_cast<std::size_t>(k)] = 0.0;
  for (double load : {0.8, 1.0, 1.15}) {
    const double fz = load * t.ref.fnomin_n, step = 1e-3;
    const Read lo = read_curve(bare, fz * (1 - step)), hi = read_curve(bare, fz * (1 + step));
    const double dln = std::log((1 + step) / (1 - step));
    const double peak = std::log(hi.d_n / lo.d_n) / dln;
    const double kx = std::log(hi.kx_n / lo.kx_n) / dln;
    const tyre::LoadLaws l = tyre::load_laws_at(t, fz);
    EXPECT_NEAR(l.peak_exponent, peak, 2e-3) << path << " at " << load;
    EXPECT_NEAR(l.kx_over_peak, kx / peak, 3e-3) << path << " at " << load;
    if (hi.e < 1 && lo.e < 1) {
      EXPECT_NEAR(l.e_per_peak_scale, (hi.e - lo.e) / dln / peak, 0.02) << path << " at " << load;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(PublishedTyres, LoadLaws, ::testing::ValuesIn(kPublishedTyres));

TEST(LoadLaws, HeldLawsLieAmongTheFourFilesAtTheirNominalLoads) {
  // Held where the tyre's file is not given, each law must be one these tyres have, E's load
  // slope too.
  const tyre::LoadLaws held{};
  double lo[3] = {1e9, 1e9, 1e9}, hi[3] = {-1e9, -1e9, -1e9};
  for (const char* name : kPublishedTyres) {
    const std::string path = std::string(BRAKEFIT_SOURCE_DIR) + "/sim/second/tyres/" + name;
    const tyre::Mf61Tyre t = tyre::tyre_from_tir(sim2::parse_tir(slurp(path), path).numbers, path);
    const tyre::LoadLaws l = tyre::load_laws_at(t, t.ref.fnomin_n * t.ref.lfzo);
    const double v[3] = {l.peak_exponent, l.kx_over_peak, l.e_per_peak_scale};
    for (int i = 0; i < 3; ++i) lo[i] = std::min(lo[i], v[i]), hi[i] = std::max(hi[i], v[i]);
  }
  const double h[3] = {held.peak_exponent, held.kx_over_peak, held.e_per_peak_scale};
  for (int i = 0; i < 3; ++i) {
    EXPECT_GE(h[i], lo[i]) << "law " << i;
    EXPECT_LE(h[i], hi[i]) << "law " << i;
  }
  EXPECT_GT(lo[2], 0.05);  // every file's E grows with the load
}

TEST(LoadLaws, GeneratorAsTyreReadOffItsCurvesHasItsFilesLaws) {
  // Generator A simulates the TNO 205/60R15 through its own MF 6.1 code; the referee reads its
  // laws off the Pacejka-96 equivalents at loads 1 % apart. They are the file's, worked out.
  const sim::Scenario s = sim::referee_null(can::BenchKind::Ground);
  const tyre::LoadLaws a = sim::detail::load_laws(s);
  const std::string path = std::string(BRAKEFIT_SOURCE_DIR) + "/sim/second/tyres/tno_205_60r15.tir";
  const tyre::LoadLaws f = tyre::load_laws_at(
      tyre::tyre_from_tir(sim2::parse_tir(slurp(path), path).numbers, path), s.wheel_load_n);
  EXPECT_NEAR(a.peak_exponent, f.peak_exponent, 1e-3);
  EXPECT_NEAR(a.kx_over_peak, f.kx_over_peak, 1e-3);
  EXPECT_NEAR(a.e_per_peak_scale, f.e_per_peak_scale, 2e-3);
  EXPECT_GT(std::abs(f.kx_over_peak - 1.25), 0.05);  // not the published tyres' it stands beside
}

TEST(LoadLawsRefused, AFileWithoutAReferenceLoadNamesTheKey) {
  tyre::TirNumbers n;
  n["LONGITUDINAL_COEFFICIENTS"] = {{"PCX1", 1.6}, {"PDX1", 1.1}, {"PKX1", 20.0}};
  try {
    (void)tyre::tyre_from_tir(n, "x.tir");
    FAIL() << "no FNOMIN accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("x.tir: [VERTICAL] FNOMIN missing"), std::string::npos)
        << e.what();
  }
}

TEST(LoadLawsRefused, ALoadWhereTheFileHasNoPeakFriction) {
  tyre::Mf61Tyre t;
  t.ref.fnomin_n = 4000;
  t.coef[static_cast<std::size_t>(tyre::Coef::PDX1)] = 1.0;
  t.coef[static_cast<std::size_t>(tyre::Coef::PDX2)] = -0.5;
  t.coef[static_cast<std::size_t>(tyre::Coef::PKX1)] = 20.0;
  EXPECT_NO_THROW((void)tyre::load_laws_at(t, 4000));
  EXPECT_THROW((void)tyre::load_laws_at(t, 13000), InputError);  // dfz 2.25: 1 - 1.125 < 0
}

}  // namespace
