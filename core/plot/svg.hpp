#pragma once
// Minimal SVG charts (pure: data in, SVG text out): an XY chart with labelled axes and a legend,
// and the SOM hexagon map. Every series is a <g class="series" data-name="..."> so tests and
// scripts can find it.
#include <Eigen/Core>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/som/lattice.hpp"

namespace brakefit::plot {

std::string xml_escape(std::string_view s);
/// "Nice" tick positions (1-2-5 steps) covering [lo, hi].
std::vector<double> nice_ticks(double lo, double hi, int target_count = 6);

struct Series {
  std::string name;
  std::vector<double> x;
  std::vector<double> y;
  bool points = false;  ///< markers instead of a line
  std::string color = "#1f77b4";
  bool dashed = false;
};

struct XyChart {
  std::string title;
  std::string x_label;  ///< with unit, e.g. "slip [%]"
  std::string y_label;  ///< with unit, e.g. "brake force [N]"
  std::vector<Series> series;
  int width = 800;
  int height = 500;
};

std::string render_svg(const XyChart& chart);

struct SomMap {
  std::string title;
  std::string subtitle;
  const som::HexLattice* lattice = nullptr;
  Eigen::VectorXd umatrix;            ///< per unit
  std::vector<std::size_t> hits;      ///< per unit
  std::optional<std::size_t> marked;  ///< BMU of the given curve
  std::string marked_label = "BMU of the curve";
};

std::string render_svg(const SomMap& map);

/// A palette of distinguishable colours for series.
const char* series_color(std::size_t i);

}  // namespace brakefit::plot
