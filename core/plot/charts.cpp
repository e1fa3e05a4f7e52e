#include "core/plot/charts.hpp"

#include <fmt/format.h>

#include "core/event_json.hpp"
#include "core/plot/svg.hpp"

namespace brakefit::plot {

std::string fit_chart_svg(const std::string& title, const Curve& measured,
                          const std::vector<MethodResult>& results, SlipUnit axis_unit) {
  const double k = axis_unit == SlipUnit::Percent ? 100.0 : 1.0;
  XyChart c;
  c.title = title;
  c.x_label = axis_unit == SlipUnit::Percent ? "slip [%]" : "slip ratio [-]";
  c.y_label = "brake force [N]";
  Series meas{"measured", {}, measured.force_n, true, "#555555", false};
  for (double s : measured.slip_ratio) meas.x.push_back(s * k);
  c.series.push_back(std::move(meas));
  const double smax = measured.max_slip_ratio();
  for (std::size_t i = 0; i < results.size(); ++i) {
    const auto& r = results[i];
    const std::string notes = result_notes(results, i);
    Series s{fmt::format("{} (MAPE {:.2f} %{})", to_string(r.method), r.metrics.mape_pct,
                         notes.empty() ? "" : "; " + notes),
             {},
             {},
             false,
             series_color(i),
             r.method == Method::Som || r.method == Method::Mlp};
    for (int j = 0; j <= 200; ++j) {
      const double x = smax * j / 200.0;
      s.x.push_back(x * k);
      s.y.push_back(mf_force_n(r.params, x));
    }
    c.series.push_back(std::move(s));
  }
  return render_svg(c);
}

}  // namespace brakefit::plot
