#include "core/tyre/charts.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "core/plot/svg.hpp"

namespace brakefit::tyre {

namespace {

double file_peak_n(const Mf61Tyre& t, const OperatingPoint& op) {
  double best = 0;
  for (int k = 1; k <= 200; ++k) best = std::max(best, braking_force_n(t, op, k / 200.0));
  return best;
}

}  // namespace

std::string curves_svg(const std::string& title, const Mf61Tyre& t,
                       const std::vector<TyreCurve>& curves, const ScalingFit* scalings) {
  plot::XyChart chart;
  chart.title = title;
  chart.x_label = "braking slip [%]";
  chart.y_label = "brake force [N]";
  const Scalings<double> s = scalings ? Scalings<double>{scalings->value[0], scalings->value[1],
                                                         scalings->value[2], scalings->value[3]}
                                      : Scalings<double>{};
  for (std::size_t i = 0; i < curves.size(); ++i) {
    const TyreCurve& tc = curves[i];
    const std::string label =
        fmt::format("Fz {:.0f} N, {:.2f} bar", tc.op.fz_n, tc.op.pressure_pa / 1e5);
    plot::Series pts{label + " measured", {}, {}, true, plot::series_color(i), false};
    // At most ~150 markers a curve: a 1 kHz event would bury the lines.
    const std::size_t step = std::max<std::size_t>(1, tc.curve.size() / 150);
    for (std::size_t k = 0; k < tc.curve.size(); k += step) {
      pts.x.push_back(100 * tc.curve.slip_ratio[k]);
      pts.y.push_back(tc.curve.force_n[k]);
    }
    const double top = std::max(tc.curve.max_slip_ratio(), 0.05);
    plot::Series line{label + (scalings ? " file, scaled" : " file"),
                      {},
                      {},
                      false,
                      plot::series_color(i),
                      false};
    plot::Series plain{label + " file, unscaled", {}, {}, false, plot::series_color(i), true};
    for (int k = 0; k <= 100; ++k) {
      const double slip = top * k / 100.0;
      line.x.push_back(100 * slip);
      line.y.push_back(-mf61_fx<double>(t.coef.data(), t.ref, tc.op, -slip, s));
      plain.x.push_back(100 * slip);
      plain.y.push_back(braking_force_n(t, tc.op, slip));
    }
    chart.series.push_back(std::move(pts));
    chart.series.push_back(std::move(line));
    if (scalings) chart.series.push_back(std::move(plain));
  }
  return plot::render_svg(chart);
}

std::string loads_svg(const Mf61Tyre& t, const std::vector<TyreCurve>& curves) {
  plot::XyChart chart;
  chart.title = "Peak friction over wheel load: measured curves and the MF 6.1 file";
  chart.x_label = "wheel load [N]";
  chart.y_label = "peak friction coefficient [-]";
  double lo = INFINITY, hi = 0;
  std::map<long, std::vector<const TyreCurve*>> by_pressure;  // kPa
  for (const auto& tc : curves) {
    lo = std::min(lo, tc.op.fz_n);
    hi = std::max(hi, tc.op.fz_n);
    by_pressure[std::lround(tc.op.pressure_pa / 1e3)].push_back(&tc);
  }
  lo *= 0.8;
  hi *= 1.2;
  std::size_t colour = 0;
  for (const auto& [kpa, group] : by_pressure) {
    const std::string p = fmt::format("{:.2f} bar", static_cast<double>(kpa) / 100.0);
    plot::Series pts{"measured, " + p, {}, {}, true, plot::series_color(colour), false};
    for (const TyreCurve* tc : group) {
      pts.x.push_back(tc->op.fz_n);
      pts.y.push_back(tc->curve.peak_abs_force_n() / tc->op.fz_n);
    }
    plot::Series line{"MF 6.1 file, " + p, {}, {}, false, plot::series_color(colour), false};
    OperatingPoint op = group.front()->op;
    for (int k = 0; k <= 40; ++k) {
      op.fz_n = lo + (hi - lo) * k / 40.0;
      line.x.push_back(op.fz_n);
      line.y.push_back(file_peak_n(t, op) / op.fz_n);
    }
    chart.series.push_back(std::move(pts));
    chart.series.push_back(std::move(line));
    ++colour;
  }
  return plot::render_svg(chart);
}

}  // namespace brakefit::tyre
