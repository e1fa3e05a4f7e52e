#include "core/plot/svg.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

namespace brakefit::plot {

std::string xml_escape(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::vector<double> nice_ticks(double lo, double hi, int target_count) {
  if (!(hi > lo)) hi = lo + 1.0;
  const double raw = (hi - lo) / std::max(1, target_count);
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    step = m * mag;
    if (step >= raw) break;
  }
  std::vector<double> t;
  const auto first = static_cast<long>(std::ceil(lo / step - 1e-9));
  const auto last = static_cast<long>(std::floor(hi / step + 1e-9));
  for (long k = first; k <= last; ++k) t.push_back(static_cast<double>(k) * step);
  return t;
}

const char* series_color(std::size_t i) {
  static const char* kColors[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd",
                                  "#ff7f0e", "#8c564b", "#17becf"};
  return kColors[i % std::size(kColors)];
}

namespace {

std::string fmt_tick(double v, double step) {
  const int decimals = std::max(0, -static_cast<int>(std::floor(std::log10(step) + 1e-9)));
  return fmt::format("{:.{}f}", v, decimals);
}

}  // namespace

std::string render_svg(const XyChart& c) {
  const double ml = 80, mr = 230, mt = 50, mb = 60;
  const double pw = c.width - ml - mr, ph = c.height - mt - mb;
  double xmin = INFINITY, xmax = -INFINITY, ymin = INFINITY, ymax = -INFINITY;
  for (const auto& s : c.series)
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (!std::isfinite(s.x[i]) || !std::isfinite(s.y[i])) continue;
      xmin = std::min(xmin, s.x[i]);
      xmax = std::max(xmax, s.x[i]);
      ymin = std::min(ymin, s.y[i]);
      ymax = std::max(ymax, s.y[i]);
    }
  if (!std::isfinite(xmin)) xmin = 0, xmax = 1, ymin = 0, ymax = 1;
  xmin = std::min(xmin, 0.0);
  ymin = std::min(ymin, 0.0);
  const auto xt = nice_ticks(xmin, xmax), yt = nice_ticks(ymin, ymax * 1.05);
  xmin = std::min(xmin, xt.front());
  xmax = std::max(xmax, xt.back());
  ymin = std::min(ymin, yt.front());
  ymax = std::max(ymax * 1.05, yt.back());
  auto X = [&](double v) { return ml + (v - xmin) / (xmax - xmin) * pw; };
  auto Y = [&](double v) { return mt + ph - (v - ymin) / (ymax - ymin) * ph; };
  // The canvas grows to hold the whole legend (one 20 px row per series, names at about 7 px a
  // character at 12 px): a gap report's 18 series and long run names were cut off.
  std::size_t longest = 0;
  for (const auto& se : c.series) longest = std::max(longest, se.name.size());
  const int canvas_w =
      std::max(c.width, static_cast<int>(ml + pw + 45 + 7.0 * static_cast<double>(longest) + 10));
  const int canvas_h =
      std::max(c.height, static_cast<int>(mt + 20 + 20 * static_cast<double>(c.series.size())));
  std::string s = fmt::format(
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\" "
      "width=\"{}\" "
      "height=\"{}\" viewBox=\"0 0 {} {}\" font-family=\"sans-serif\" font-size=\"12\">\n",
      canvas_w, canvas_h, canvas_w, canvas_h);
  s += fmt::format("<rect width=\"{}\" height=\"{}\" fill=\"white\"/>\n", canvas_w, canvas_h);
  s += fmt::format(
      "<text class=\"title\" x=\"{}\" y=\"28\" font-size=\"16\" text-anchor=\"middle\">{}</text>\n",
      ml + pw / 2, xml_escape(c.title));
  s += "<g class=\"axes\" stroke=\"#444\">\n";
  s += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\"/>\n", ml, mt,
                   pw, ph);
  const double xstep = xt.size() > 1 ? xt[1] - xt[0] : 1.0,
               ystep = yt.size() > 1 ? yt[1] - yt[0] : 1.0;
  for (double v : xt) {
    s += fmt::format(
        "<line x1=\"{0:.2f}\" y1=\"{1:.2f}\" x2=\"{0:.2f}\" y2=\"{2:.2f}\" stroke=\"#ddd\"/>", X(v),
        mt, mt + ph);
    s += fmt::format(
        "<text x=\"{:.2f}\" y=\"{:.2f}\" text-anchor=\"middle\" stroke=\"none\">{}</text>\n", X(v),
        mt + ph + 18, fmt_tick(v, xstep));
  }
  for (double v : yt) {
    s += fmt::format(
        "<line x1=\"{0:.2f}\" y1=\"{1:.2f}\" x2=\"{2:.2f}\" y2=\"{1:.2f}\" stroke=\"#ddd\"/>", ml,
        Y(v), ml + pw);
    s += fmt::format(
        "<text x=\"{:.2f}\" y=\"{:.2f}\" text-anchor=\"end\" stroke=\"none\">{}</text>\n", ml - 6,
        Y(v) + 4, fmt_tick(v, ystep));
  }
  s += "</g>\n";
  s += fmt::format("<text class=\"x-label\" x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n",
                   ml + pw / 2, c.height - 15, xml_escape(c.x_label));
  s += fmt::format(
      "<text class=\"y-label\" x=\"18\" y=\"{0}\" text-anchor=\"middle\" transform=\"rotate(-90 18 "
      "{0})\">{1}</text>\n",
      mt + ph / 2, xml_escape(c.y_label));
  for (const auto& se : c.series) {
    s += fmt::format("<g class=\"series\" data-name=\"{}\">\n", xml_escape(se.name));
    if (se.points) {
      for (std::size_t i = 0; i < se.x.size(); ++i)
        if (std::isfinite(se.x[i]) && std::isfinite(se.y[i]))
          s += fmt::format(
              "<circle cx=\"{:.2f}\" cy=\"{:.2f}\" r=\"2.2\" fill=\"{}\" fill-opacity=\"0.6\"/>\n",
              X(se.x[i]), Y(se.y[i]), se.color);
    } else {
      s += fmt::format("<polyline fill=\"none\" stroke=\"{}\" stroke-width=\"2\"{} points=\"",
                       se.color, se.dashed ? " stroke-dasharray=\"6 4\"" : "");
      for (std::size_t i = 0; i < se.x.size(); ++i)
        if (std::isfinite(se.x[i]) && std::isfinite(se.y[i]))
          s += fmt::format("{:.2f},{:.2f} ", X(se.x[i]), Y(se.y[i]));
      s += "\"/>\n";
    }
    s += "</g>\n";
  }
  s += "<g class=\"legend\">\n";
  double ly = mt + 10;
  for (const auto& se : c.series) {
    const double lx = ml + pw + 15;
    if (se.points)
      s += fmt::format("<circle cx=\"{}\" cy=\"{}\" r=\"4\" fill=\"{}\"/>", lx + 12, ly, se.color);
    else
      s += fmt::format(
          "<line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"{}\" stroke-width=\"2\"{}/>", lx,
          ly, lx + 24, ly, se.color, se.dashed ? " stroke-dasharray=\"6 4\"" : "");
    s += fmt::format("<text x=\"{}\" y=\"{}\">{}</text>\n", lx + 30, ly + 4, xml_escape(se.name));
    ly += 20;
  }
  s += "</g>\n</svg>\n";
  return s;
}

std::string render_svg(const SomMap& m) {
  const auto& lat = *m.lattice;
  const double cell = 46.0;                // lattice unit in pixels
  const double r = cell / std::sqrt(3.0);  // hexagon circumradius: neighbours touch
  const double ml = 40, mt = 70;
  const double map_w = (static_cast<double>(lat.cols()) + 0.5) * cell;
  const double map_h = (static_cast<double>(lat.rows()) - 1) * cell * std::sqrt(0.75) + 2 * r;
  const int width = static_cast<int>(ml + map_w + 210), height = static_cast<int>(mt + map_h + 40);
  const double umin = m.umatrix.size() ? m.umatrix.minCoeff() : 0.0;
  const double umax = m.umatrix.size() ? m.umatrix.maxCoeff() : 1.0;
  auto shade = [&](double u) {
    const double t = umax > umin ? (u - umin) / (umax - umin) : 0.0;  // 0 = valley (light)
    const int v = static_cast<int>(std::lround(245 - 185 * t));
    return fmt::format("rgb({},{},{})", v, v, std::min(255, v + 10));
  };
  std::string s = fmt::format(
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\" "
      "width=\"{0}\" "
      "height=\"{1}\" viewBox=\"0 0 {0} {1}\" font-family=\"sans-serif\" font-size=\"11\">\n"
      "<rect width=\"{0}\" height=\"{1}\" fill=\"white\"/>\n",
      width, height);
  s += fmt::format("<text class=\"title\" x=\"{}\" y=\"26\" font-size=\"16\">{}</text>\n", ml,
                   xml_escape(m.title));
  s += fmt::format("<text class=\"subtitle\" x=\"{}\" y=\"46\">{}</text>\n", ml,
                   xml_escape(m.subtitle));
  s += "<g class=\"series\" data-name=\"units\">\n";
  for (std::size_t u = 0; u < lat.size(); ++u) {
    const double cx = ml + r + lat.x(u) * cell, cy = mt + r + lat.y(u) * cell;
    std::string pts;
    for (int k = 0; k < 6; ++k) {
      const double a = M_PI / 180.0 * (30.0 + 60.0 * k);
      pts += fmt::format("{:.2f},{:.2f} ", cx + r * std::cos(a), cy + r * std::sin(a));
    }
    const double uval = u < static_cast<std::size_t>(m.umatrix.size())
                            ? m.umatrix(static_cast<Eigen::Index>(u))
                            : 0.0;
    const std::size_t hits = u < m.hits.size() ? m.hits[u] : 0;
    s += fmt::format(
        "<polygon class=\"unit\" data-unit=\"{}\" data-hits=\"{}\" data-umatrix=\"{:.6g}\" "
        "points=\"{}\" "
        "fill=\"{}\" stroke=\"#888\"/>",
        u, hits, uval, pts, shade(uval));
    if (hits)
      s += fmt::format("<text x=\"{:.2f}\" y=\"{:.2f}\" text-anchor=\"middle\">{}</text>", cx,
                       cy + 4, hits);
    s += "\n";
  }
  s += "</g>\n";
  if (m.marked) {
    const std::size_t u = *m.marked;
    const double cx = ml + r + lat.x(u) * cell, cy = mt + r + lat.y(u) * cell;
    s += fmt::format(
        "<g class=\"series\" data-name=\"bmu\"><circle data-unit=\"{}\" cx=\"{:.2f}\" "
        "cy=\"{:.2f}\" r=\"{:.2f}\" "
        "fill=\"none\" stroke=\"#d62728\" stroke-width=\"3\"/></g>\n",
        u, cx, cy, r * 0.8);
  }
  // Legend: U-matrix scale and marks.
  const double lx = ml + map_w + 30;
  s += "<g class=\"legend\">\n";
  s += fmt::format("<text x=\"{}\" y=\"{}\">U-matrix (mean distance</text>", lx, mt + 4);
  s += fmt::format("<text x=\"{}\" y=\"{}\">to neighbours)</text>\n", lx, mt + 18);
  for (int i = 0; i <= 4; ++i) {
    const double u = umin + (umax - umin) * i / 4.0;
    s += fmt::format(
        "<rect x=\"{}\" y=\"{}\" width=\"18\" height=\"18\" fill=\"{}\" stroke=\"#888\"/>", lx,
        mt + 30 + i * 22, shade(u));
    s += fmt::format("<text x=\"{}\" y=\"{}\">{:.3g}</text>\n", lx + 24, mt + 43 + i * 22, u);
  }
  s += fmt::format("<text x=\"{}\" y=\"{}\">number = curves on unit</text>\n", lx, mt + 160);
  if (m.marked)
    s += fmt::format(
        "<circle cx=\"{}\" cy=\"{}\" r=\"7\" fill=\"none\" stroke=\"#d62728\" "
        "stroke-width=\"3\"/><text x=\"{}\" "
        "y=\"{}\">{}</text>\n",
        lx + 9, mt + 180, lx + 24, mt + 184, xml_escape(m.marked_label));
  s += "</g>\n</svg>\n";
  return s;
}

}  // namespace brakefit::plot
