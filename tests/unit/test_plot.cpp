#include <gtest/gtest.h>

#include "core/plot/charts.hpp"
#include "core/plot/svg.hpp"

using namespace brakefit;
using namespace brakefit::plot;

TEST(Svg, EscapesAndTicks) {
  EXPECT_EQ(xml_escape("a<b & \"c\""), "a&lt;b &amp; &quot;c&quot;");
  const auto t = nice_ticks(0, 4321, 6);
  ASSERT_FALSE(t.empty());
  EXPECT_DOUBLE_EQ(t.front(), 0.0);
  EXPECT_DOUBLE_EQ(t[1] - t[0], 1000.0);
  EXPECT_GE(t.back(), 4000.0);
  const auto s = nice_ticks(0, 0.27, 6);
  EXPECT_NEAR(s[1] - s[0], 0.05, 1e-12);
}

TEST(Svg, FitChartHasAxesWithUnitsLegendAndOneGroupPerSeries) {
  const MfParams p{15, 1.6, 4000, 0.3, 0, 0};
  const Curve c = sample_curve(p, even_slips(30, 0.27));
  MethodResult r;
  r.method = Method::Lm;
  r.params = p;
  const std::string svg = fit_chart_svg("t <1>", c, {r}, SlipUnit::Percent);
  EXPECT_NE(svg.find("slip [%]"), std::string::npos);
  EXPECT_NE(svg.find("brake force [N]"), std::string::npos);
  EXPECT_NE(svg.find("data-name=\"measured\""), std::string::npos);
  EXPECT_NE(svg.find("data-name=\"lm (MAPE"), std::string::npos);
  EXPECT_NE(svg.find("class=\"legend\""), std::string::npos);
  EXPECT_NE(svg.find("t &lt;1&gt;"), std::string::npos);
}
