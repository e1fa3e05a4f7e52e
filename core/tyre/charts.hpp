#pragma once
// Pictures of an MF 6.1 fit (pure: data in, SVG text out): the measured curves against the file's
// curves at their loads and pressures, and peak friction over load.
#include <string>
#include <vector>

#include "core/tyre/mf61_fit.hpp"
#include "core/tyre/scaling.hpp"

namespace brakefit::tyre {

/// Measured points (thinned) and the file's curve for each curve; with scalings, the scaled file
/// (solid) and the unscaled file (dashed).
std::string curves_svg(const std::string& title, const Mf61Tyre& t,
                       const std::vector<TyreCurve>& curves, const ScalingFit* scalings = nullptr);
/// Peak friction coefficient (peak force / load) per load: each curve's
/// measured value as a point, the file's law as a line per pressure.
std::string loads_svg(const Mf61Tyre& t, const std::vector<TyreCurve>& curves);

}  // namespace brakefit::tyre
