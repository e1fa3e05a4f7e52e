#include <gtest/gtest.h>

#include <cmath>

#include "core/curve.hpp"
#include "core/fit/mf_fit.hpp"
#include "core/rng.hpp"

using namespace brakefit;
using namespace brakefit::fit;

namespace {

class Linear final : public LeastSquaresProblem {
 public:
  Eigen::Index residual_count() const override { return 5; }
  void evaluate(const Eigen::VectorXd& x, Eigen::VectorXd& r, Eigen::MatrixXd* j) const override {
    for (int i = 0; i < 5; ++i) {
      r(i) = x(0) + x(1) * i - (1.0 + 2.0 * i + (i % 2 ? 0.1 : -0.1));
      if (j) (*j)(i, 0) = 1, (*j)(i, 1) = i;
    }
  }
};

/// The Linear problem with a second intercept x(2) on the same column as x(0) (only their sum is
/// determined).
class SharedIntercept final : public LeastSquaresProblem {
 public:
  Eigen::Index residual_count() const override { return 5; }
  void evaluate(const Eigen::VectorXd& x, Eigen::VectorXd& r, Eigen::MatrixXd* j) const override {
    Linear().evaluate(x.head(2), r, nullptr);
    r.array() += x(2);
    if (j) {
      Eigen::MatrixXd j2(5, 2);
      Linear().evaluate(x.head(2), r, &j2);
      r.array() += x(2);
      j->leftCols(2) = j2;
      j->col(2).setOnes();
    }
  }
};

}  // namespace

TEST(Lm, SolvesLinearLeastSquares) {
  Eigen::VectorXd lo(2), hi(2), x0(2);
  lo << -100, -100;
  hi << 100, 100;
  x0 << 50, -50;
  const LmResult r = minimize(Linear(), x0, lo, hi);
  ASSERT_TRUE(r.converged);
  // Normal equations of y = 1 + 2 i +/- 0.1 for i = 0..4: slope 2, intercept 1 - 0.02.
  EXPECT_NEAR(r.x(1), 2.0, 1e-9);
  EXPECT_NEAR(r.x(0), 1.0 - 0.02, 1e-9);
}

TEST(Lm, RespectsBoundsAndMarksParameterAtBound) {
  Eigen::VectorXd lo(2), hi(2), x0(2);
  lo << -100, -100;
  hi << 100, 1.5;  // slope capped below the unconstrained 2
  x0 << 0, 0;
  const LmResult r = minimize(Linear(), x0, lo, hi);
  EXPECT_DOUBLE_EQ(r.x(1), 1.5);
  EXPECT_TRUE(r.at_bound[1]);
  EXPECT_TRUE(std::isnan(r.standard_errors(1)));
  EXPECT_TRUE(std::isfinite(r.standard_errors(0)));
}

TEST(Lm, AParameterSharingAColumnHasAnErrorOnceTheOtherIsHeld) {
  Eigen::VectorXd lo(3), hi(3), x0(3);
  lo << -100, -100, -10;
  hi << 100, 100, 10;  // a bounded nuisance on the intercept's column
  x0 << 0, 0, 0;
  const LmResult shared = minimize(SharedIntercept(), x0, lo, hi);
  ASSERT_FALSE(shared.at_bound[2]);
  // Both free: only the sum is determined, the intercept's own error is none or enormous.
  EXPECT_FALSE(shared.standard_errors(0) < 1.0) << shared.standard_errors(0);
  // The nuisance held: the intercept's error is the one-intercept problem's.
  Eigen::VectorXd lo2(2), hi2(2), x02(2);
  lo2 << -100, -100;
  hi2 << 100, 100;
  x02 << 0, 0;
  const LmResult alone = minimize(Linear(), x02, lo2, hi2);
  const Eigen::VectorXd held = standard_errors_holding(shared, {false, false, true});
  EXPECT_NEAR(held(0), alone.standard_errors(0), 1e-6 * alone.standard_errors(0));
  EXPECT_NEAR(held(1), alone.standard_errors(1), 1e-6 * alone.standard_errors(1));
  EXPECT_TRUE(std::isnan(held(2)));
}

TEST(MfFit, RecoversNoiseFreeParametersTo1e6) {
  const MfParams cases[] = {{15, 1.6, 4500, 0.3, 0, 0},
                            {9.7, 1.55, 2100, -0.04, 0, 0},
                            {21, 1.65, 7000, 0.58, 0, 0},
                            {6, 1.4, 24000, -4, 0, 0},
                            {4.2, 1.36, 13000, -1.2, 0, 0}};
  for (const auto& t : cases) {
    const Curve c = sample_curve(t, even_slips(200, 1.0));
    const MfParams start{t.B * 1.2, t.C * 0.95, t.D * 1.1, t.E + 0.1, 0, 0};
    const MfFitResult r = fit_mf(c, start);
    EXPECT_TRUE(r.converged);
    EXPECT_NEAR(r.params.B, t.B, 1e-6 * t.B);
    EXPECT_NEAR(r.params.C, t.C, 1e-6 * t.C);
    EXPECT_NEAR(r.params.D, t.D, 1e-6 * t.D);
    EXPECT_NEAR(r.params.E, t.E, 1e-6 * std::max(1.0, std::abs(t.E)));
    EXPECT_TRUE(r.peak_reached);
  }
}

TEST(MfFit, RecoversShiftsWhenAsked) {
  const MfParams t{14, 1.6, 4000, 0.2, 0.004, 35};
  const Curve c = sample_curve(t, even_slips(200, 1.0));
  MfFitOptions o;
  o.fit_shifts = true;
  const MfFitResult r = fit_mf(c, {13, 1.55, 4100, 0.1, 0, 0}, o);
  EXPECT_NEAR(r.params.SHx, t.SHx, 1e-7);
  EXPECT_NEAR(r.params.SVx, t.SVx, 1e-5);
  EXPECT_NEAR(r.params.B, t.B, 1e-6 * t.B);
}

TEST(MfFit, StandardErrorsMatchScatterOverNoiseRealisations) {
  const MfParams t{15, 1.6, 4500, 0.3, 0, 0};
  const Curve clean = sample_curve(t, even_slips(200, 1.0));
  Rng rng(42);
  std::vector<double> bs;
  double reported = 0;
  const int n = 200;
  for (int k = 0; k < n; ++k) {
    Curve c = clean;
    for (double& f : c.force_n) f += 45.0 * rng.normal();  // 1 % of D
    const MfFitResult r = fit_mf(c, t);
    bs.push_back(r.params.B);
    reported += r.stderr_[0] / n;
  }
  double mean = 0, var = 0;
  for (double b : bs) mean += b / n;
  for (double b : bs) var += (b - mean) * (b - mean) / (n - 1);
  const double empirical = std::sqrt(var);
  EXPECT_NEAR(reported / empirical, 1.0, 0.2)
      << "reported " << reported << " empirical " << empirical;
  EXPECT_NEAR(mean, t.B, 3 * empirical / std::sqrt(n) + 1e-3);
}

TEST(MfFit, FlagsPeakBeyondTheData) {
  // Soft tyre whose peak lies past a roller test's 27 % switch-off.
  const MfParams t{4, 1.5, 3000, 0.0, 0, 0};  // peak at tan(pi/3)/4 = 0.433
  const Curve c = sample_curve(t, even_slips(100, 0.27));
  const MfFitResult r = fit_mf(c, {5, 1.5, 2800, 0.1, 0, 0});
  EXPECT_FALSE(r.peak_reached);
  const Curve full = sample_curve(t, even_slips(100, 1.0));
  EXPECT_TRUE(fit_mf(full, {5, 1.5, 2800, 0.1, 0, 0}).peak_reached);
}
