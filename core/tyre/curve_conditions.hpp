#pragma once
// Where a curve CSV was measured, from its header comment lines (pure: text in, values out):
//   # wheel_load_n=3800
//   # tyre_pressure_bar=2.2    (optional)
//   # speed_kmh=5              (optional)
//   # wheel_radius_m=0.3       (optional)
// Other comment lines are free text and ignored.
#include <cmath>
#include <string>
#include <string_view>

namespace brakefit::tyre {

struct CurveConditions {
  double wheel_load_n = NAN;  ///< NaN: not given
  double tyre_pressure_bar = NAN;
  double speed_kmh = NAN;
  double wheel_radius_m = NAN;
};

/// Throws InputError "FILE:LINE: KEY: ..." for a value that is not a positive, finite number.
CurveConditions parse_curve_conditions(std::string_view text, const std::string& filename);

}  // namespace brakefit::tyre
