#pragma once
// Domain charts built on svg.hpp: measured curve vs fitted curves.
#include <string>
#include <vector>

#include "core/curve.hpp"
#include "core/curve_csv.hpp"
#include "core/identify.hpp"

namespace brakefit::plot {

/// Measured points and one line per method result; slip axis in the given unit.
std::string fit_chart_svg(const std::string& title, const Curve& measured,
                          const std::vector<MethodResult>& results, SlipUnit axis_unit);

}  // namespace brakefit::plot
