#pragma once
// Goodness of a fitted curve against a measured one.
// MAPE (paper Eq. 5) = 100/N * sum |F_meas - F_model| / |F_meas| over the measured points, where
// project-wide points with |F_meas| < 5 % of the measured peak (max |F_meas|) are excluded (they
// blow MAPE up near zero slip); their count is reported.
#include <cstddef>

#include "core/curve.hpp"
#include "core/magic_formula.hpp"

namespace brakefit {

inline constexpr double kMapeExcludeFractionOfPeak = 0.05;
inline constexpr const char* kMapeRule =
    "points with |force| < 5 % of the measured peak are excluded from MAPE";

struct FitMetrics {
  double mape_pct = 0.0;
  std::size_t mape_points_used = 0;
  std::size_t mape_points_excluded = 0;
  double rmse_n = 0.0;
  double rmse_pct_peak = 0.0;       ///< RMSE as % of the measured peak
  double peak_force_error_n = 0.0;  ///< model peak - measured peak (within the data's slip range)
  double peak_slip_error_ratio = 0.0;  ///< slip at model peak - slip at measured peak
};

FitMetrics compute_metrics(const Curve& measured, const MfParams& p);

}  // namespace brakefit
