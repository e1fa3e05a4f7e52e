#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "core/curve.hpp"
#include "core/curve_csv.hpp"
#include "core/metrics.hpp"

using namespace brakefit;

namespace {

std::string rows(int n, double slip_scale = 0.01) {
  std::string s;
  for (int i = 1; i <= n; ++i)
    s += std::to_string(i * slip_scale) + "," + std::to_string(100.0 * i) + "\n";
  return s;
}

std::string error_of(const std::string& text) {
  try {
    parse_curve_csv(text, "c.csv");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(CurveCsv, ParsesRatioAndPercentHeaders) {
  const ParsedCurve a = parse_curve_csv("# comment\nslip,force_n\n" + rows(10), "a.csv");
  EXPECT_EQ(a.input_unit, SlipUnit::Ratio);
  ASSERT_EQ(a.curve.size(), 10u);
  EXPECT_DOUBLE_EQ(a.curve.slip_ratio[2], 0.03);
  EXPECT_DOUBLE_EQ(a.curve.force_n[2], 300.0);
  const ParsedCurve b = parse_curve_csv("force_n,slip_pct,extra\r\n" +
                                            std::string("100,1,x\r\n200,2,y\r\n300,3,z\n") +
                                            "400,4,a\n500,5,b\n600,6,c\n700,7,d\n800,8.5,e\n\n",
                                        "b.csv");
  EXPECT_EQ(b.input_unit, SlipUnit::Percent);
  ASSERT_EQ(b.curve.size(), 8u);
  EXPECT_DOUBLE_EQ(b.curve.slip_ratio[7], 0.085);
  EXPECT_DOUBLE_EQ(b.curve.force_n[7], 800.0);
}

TEST(CurveCsv, ErrorsNameFileAndLine) {
  EXPECT_EQ(error_of("slip,force\n" + rows(10)).rfind("c.csv:1: header", 0), 0u);
  EXPECT_EQ(error_of("slip,force_n\n0.1,100\n0.2,abc\n" + rows(10))
                .rfind("c.csv:3: column 'force_n': 'abc' is not a number", 0),
            0u);
  EXPECT_EQ(error_of("slip,force_n\n0.1,100\nnan,200\n" + rows(10))
                .rfind("c.csv:3: column 'slip': value 'nan' is not finite", 0),
            0u);
  EXPECT_EQ(error_of("slip,force_n\n" + rows(5) + "1.2,5\n" + rows(5))
                .rfind("c.csv:7: column 'slip': slip 1.2 is outside", 0),
            0u);
  EXPECT_EQ(
      error_of("slip_pct,force_n\n1,1\n150,2\n" + rows(10)).rfind("c.csv:3: column 'slip_pct'", 0),
      0u);
  EXPECT_EQ(error_of("slip,force_n\n0.1,1,7\n" + rows(10)).rfind("c.csv:2: expected 2 columns", 0),
            0u);
  EXPECT_EQ(
      error_of("slip,force_n\n" + rows(7)).rfind("c.csv:9: only 7 data points; at least 8", 0), 0u);
  EXPECT_EQ(error_of("slip,force_n\n0.1,\n" + rows(10))
                .rfind("c.csv:2: column 'force_n': '' is not a number", 0),
            0u);
  EXPECT_EQ(error_of("").rfind("c.csv:1: no header", 0), 0u);
}

TEST(Grid, ResampleMasksBeyondTheDataAndSmoothsNoise) {
  const auto grid = default_slip_grid();
  ASSERT_EQ(grid.size(), 48u);
  EXPECT_DOUBLE_EQ(grid.front(), 0.01);
  EXPECT_DOUBLE_EQ(grid.back(), 1.0);
  const MfParams p{15, 1.6, 4000, 0.3, 0, 0};
  const Curve roller = sample_curve(p, even_slips(300, 0.27));
  const GridCurve g = resample_to_grid(roller, grid);
  for (std::size_t k = 0; k < grid.size(); ++k) {
    EXPECT_EQ(g.mask[k], grid[k] <= 0.27 + 1e-9) << grid[k];
    if (g.mask[k]) {
      EXPECT_NEAR(g.values[k], mf_force_n(p, grid[k]),
                  0.01 * 4000);  // local regression of a smooth curve
    }
  }
  EXPECT_EQ(g.valid_count(), 27u);
  EXPECT_DOUBLE_EQ(g.last_valid_slip(grid), 0.27);
  // Sparse data (fewer than 3 points per cell): linear interpolation, exact for a straight line.
  Curve line;
  for (int i = 0; i <= 10; ++i) {
    line.slip_ratio.push_back(0.1 * i);
    line.force_n.push_back(1000 * 0.1 * i);
  }
  const GridCurve gl = resample_to_grid(line, grid);
  for (std::size_t k = 0; k < grid.size(); ++k) EXPECT_NEAR(gl.values[k], 1000 * grid[k], 1e-9);
}

TEST(Metrics, MapeExcludesPointsBelowFivePercentOfPeakAndCountsThem) {
  const MfParams zero{10, 1.5, 0.0, 0, 0, 0};  // model force 0 everywhere
  Curve c;
  c.slip_ratio = {0.0, 0.1, 0.2, 0.3};
  c.force_n = {10.0, 1000.0, 500.0, 40.0};  // 10 and 40 N are below 5 % of 1000 N
  const FitMetrics m = compute_metrics(c, zero);
  EXPECT_EQ(m.mape_points_excluded, 2u);
  EXPECT_EQ(m.mape_points_used, 2u);
  EXPECT_DOUBLE_EQ(m.mape_pct, 100.0);
  EXPECT_NEAR(m.rmse_n, std::sqrt((100.0 + 1e6 + 2.5e5 + 1600.0) / 4), 1e-9);
  EXPECT_NEAR(m.rmse_pct_peak, 100 * m.rmse_n / 1000, 1e-12);
  // A perfect model: zero error everywhere.
  const MfParams p{15, 1.6, 4000, 0.3, 0, 0};
  const FitMetrics perfect = compute_metrics(sample_curve(p, even_slips(50, 1.0)), p);
  EXPECT_NEAR(perfect.mape_pct, 0.0, 1e-12);
  EXPECT_NEAR(perfect.peak_force_error_n, 0.0, 5.0);  // measured peak is the best sample
}
