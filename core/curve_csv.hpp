#pragma once
// Parses a brake-slip curve CSV (pure: text in, curve out). The header decides the slip unit:
// `slip,force_n` (ratio) or `slip_pct,force_n` (percent). Lines starting with '#' and blank lines
// are skipped; extra columns are ignored.
#include <string>
#include <string_view>

#include "core/curve.hpp"

namespace brakefit {

enum class SlipUnit { Ratio, Percent };
const char* to_string(SlipUnit u);

struct ParsedCurve {
  Curve curve;  ///< slip always as a ratio
  SlipUnit input_unit = SlipUnit::Ratio;
};

inline constexpr std::size_t kMinCurvePoints = 8;

/// Throws InputError "FILE:LINE: message" on missing columns, non-numeric or non-finite values,
/// slip outside [0, 1] (after unit conversion) or fewer than kMinCurvePoints points.
ParsedCurve parse_curve_csv(std::string_view text, const std::string& filename);

}  // namespace brakefit
