#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/rng.hpp"
#include "core/vecmath.hpp"

using namespace brakefit;

namespace {

/// Values over the gap fits' ranges (and a length that leaves a tail of three past the lanes).
std::vector<double> draws(double lo, double hi, std::size_t n = 1003) {
  Rng rng(17);
  std::vector<double> x(n);
  for (double& v : x) v = rng.uniform(lo, hi);
  return x;
}

/// Largest distance from the scalar function, in units of the scalar result's spacing.
template <class Vec, class Scalar>
double worst_ulps(std::vector<double> x, Vec vec, Scalar scalar) {
  const std::vector<double> in = x;
  vec(std::span<double>(x));
  double worst = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double want = scalar(in[i]);
    const double ulp = std::nextafter(std::abs(want), INFINITY) - std::abs(want);
    worst = std::max(worst, std::abs(x[i] - want) / ulp);
  }
  return worst;
}

}  // namespace

TEST(VectorMath, AgreesWithTheScalarFunctionsWithinFourUlpAndKeepsTheTail) {
  // libmvec promises 4 ulp; the scalar path is exact to itself.
  const double tol = vector_math_available() ? 4.0 : 0.0;
  EXPECT_LE(worst_ulps(draws(-60, 60), atan_in_place, [](double v) { return std::atan(v); }), tol);
  EXPECT_LE(worst_ulps(draws(-3.2, 3.2), sin_in_place, [](double v) { return std::sin(v); }), tol);
  EXPECT_LE(worst_ulps(draws(-40, 2), exp_in_place, [](double v) { return std::exp(v); }), tol);
  EXPECT_LE(worst_ulps(draws(0.05, 3), log_in_place, [](double v) { return std::log(v); }), tol);
  // Lengths below one lane set and at its edges: every element is computed, none beyond.
  for (std::size_t n : {0u, 1u, 3u, 4u, 5u}) {
    std::vector<double> x(n + 1, 0.5);
    x[n] = -7.0;  // a guard past the span
    atan_in_place(std::span<double>(x.data(), n));
    for (std::size_t i = 0; i < n; ++i) EXPECT_NEAR(x[i], std::atan(0.5), 1e-15) << n;
    EXPECT_EQ(x[n], -7.0) << n;
  }
}
