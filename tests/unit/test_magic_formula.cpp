#include <gtest/gtest.h>

#include <cmath>

#include "core/magic_formula.hpp"
#include "core/rng.hpp"

using namespace brakefit;

namespace {

MfParams random_params(Rng& rng) {
  return {rng.uniform(2, 40), rng.uniform(0.8, 2.2),    rng.uniform(500, 9000),
          rng.uniform(-5, 1), rng.uniform(-0.01, 0.01), rng.uniform(-50, 50)};
}

}  // namespace

TEST(MagicFormula, HandComputedValues) {
  // B=10, C=1.5, D=1000, E=0 at slip 0.1: Bx = 1, atan(1) = pi/4, F = 1000 sin(1.5 pi/4).
  EXPECT_NEAR(mf_force_n({10, 1.5, 1000, 0, 0, 0}, 0.1), 923.8795325, 1e-6);
  // E = 1: phi = atan(Bx) = pi/4; F = 1000 sin(1.5 atan(pi/4)) = 840.65...
  EXPECT_NEAR(mf_force_n({10, 1.5, 1000, 1, 0, 0}, 0.1), 1000 * std::sin(1.5 * std::atan(M_PI / 4)),
              1e-9);
  EXPECT_EQ(mf_force_n({10, 1.5, 1000, 0.5, 0, 0}, 0.0), 0.0);
}

TEST(MagicFormula, MatchesPaperFormOfEquation2) {
  // Paper Eq. 2: D sin[C arctan{B(1-E)x + E arctan(Bx)}] with shifts x -> x + SHx, F -> F + SVx.
  Rng rng(5);
  for (int i = 0; i < 100; ++i) {
    const MfParams p = random_params(rng);
    const double s = rng.uniform(0, 1);
    const double x = s + p.SHx;
    const double paper =
        p.D * std::sin(p.C * std::atan(p.B * (1 - p.E) * x + p.E * std::atan(p.B * x))) + p.SVx;
    EXPECT_NEAR(mf_force_n(p, s), paper, 1e-9 * p.D);
  }
}

TEST(MagicFormula, AnalyticJacobianMatchesFiniteDifferences) {
  Rng rng(6);
  for (int i = 0; i < 200; ++i) {
    const MfParams p = random_params(rng);
    const double s = rng.uniform(0.001, 1);
    MfGradient g;
    const double f = mf_force_and_gradient(p, s, g);
    EXPECT_DOUBLE_EQ(f, mf_force_n(p, s));
    auto a = to_array(p);
    for (std::size_t k = 0; k < kMfParamCount; ++k) {
      const double h = 1e-6 * std::max(1.0, std::abs(a[k]));
      auto ap = a, am = a;
      ap[k] += h;
      am[k] -= h;
      const double fd = (mf_force_n(from_array(ap), s) - mf_force_n(from_array(am), s)) / (2 * h);
      EXPECT_NEAR(g[k], fd, 1e-5 * std::max(1.0, std::abs(fd)))
          << "parameter " << k << " case " << i;
    }
  }
}

TEST(MagicFormula, PeakWhereArgumentReachesTanPiOver2C) {
  // E = 0: the peak is at B x = tan(pi / (2C)) with F = D.
  const MfParams p{10, 1.5, 1000, 0, 0, 0};
  const MfPeak pk = mf_peak(p, 1.0);
  EXPECT_NEAR(pk.slip_ratio, std::tan(M_PI / 3) / 10, 1e-6);
  EXPECT_NEAR(pk.force_n, 1000, 1e-6);
  EXPECT_TRUE(pk.interior);
  // Cut before the peak: not interior.
  EXPECT_FALSE(mf_peak(p, 0.1).interior);
  // C < 1 never turns over: the maximum is at the end of the range.
  const MfPeak mono = mf_peak({10, 0.9, 1000, 0, 0, 0}, 0.27);
  EXPECT_FALSE(mono.interior);
  EXPECT_NEAR(mono.slip_ratio, 0.27, 1e-12);
}
