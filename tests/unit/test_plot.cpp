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

TEST(Svg, TheCanvasGrowsToHoldEveryLegendEntry) {
  // A gap report: 18 series with long run names used to be cut at the 800 x 500 canvas.
  XyChart c{"t", "slip [%]", "brake force [N]", {}, 800, 500};
  for (int i = 0; i < 30; ++i)
    c.series.push_back({"roller_2p2bar_medium#" + std::to_string(i) + " corrected model",
                        {0.0, 1.0},
                        {0.0, 1.0},
                        false,
                        "#000000",
                        false});
  const std::string svg = render_svg(c);
  // 30 rows of 20 px below the 50 px title band need 670 px; the longest name (39 characters at
  // about 7 px) starts 45 px right of the 490 px plot that begins at 80 px: 898 px.
  EXPECT_NE(svg.find("width=\"898\" height=\"670\""), std::string::npos) << svg.substr(0, 200);
  XyChart small{"t", "x [1]", "y [1]", {{"a", {0.0}, {0.0}, true, "#000000", false}}, 800, 500};
  EXPECT_NE(render_svg(small).find("width=\"800\" height=\"500\""), std::string::npos);
}
