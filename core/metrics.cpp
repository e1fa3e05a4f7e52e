#include "core/metrics.hpp"

#include <cmath>

namespace brakefit {

FitMetrics compute_metrics(const Curve& measured, const MfParams& p) {
  FitMetrics m;
  const double peak = measured.peak_abs_force_n();
  const double threshold = kMapeExcludeFractionOfPeak * peak;
  double sum_ape = 0.0, sum_sq = 0.0;
  double meas_peak = -INFINITY, meas_peak_slip = 0.0;
  for (std::size_t i = 0; i < measured.size(); ++i) {
    const double f = measured.force_n[i];
    const double r = f - mf_force_n(p, measured.slip_ratio[i]);
    sum_sq += r * r;
    if (std::abs(f) < threshold || f == 0.0) {
      ++m.mape_points_excluded;
    } else {
      sum_ape += std::abs(r) / std::abs(f);
      ++m.mape_points_used;
    }
    if (f > meas_peak) {
      meas_peak = f;
      meas_peak_slip = measured.slip_ratio[i];
    }
  }
  m.mape_pct = m.mape_points_used ? 100.0 * sum_ape / static_cast<double>(m.mape_points_used) : NAN;
  m.rmse_n = measured.size() ? std::sqrt(sum_sq / static_cast<double>(measured.size())) : NAN;
  m.rmse_pct_peak = peak > 0 ? 100.0 * m.rmse_n / peak : NAN;
  const MfPeak model_peak = mf_peak(p, measured.max_slip_ratio());
  m.peak_force_error_n = model_peak.force_n - meas_peak;
  m.peak_slip_error_ratio = model_peak.slip_ratio - meas_peak_slip;
  return m;
}

}  // namespace brakefit
