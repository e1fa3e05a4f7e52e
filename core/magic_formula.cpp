#include "core/magic_formula.hpp"

#include <cmath>

namespace brakefit {

double mf_force_n(const MfParams& p, double slip_ratio) {
  const double u = p.B * (slip_ratio + p.SHx);
  const double phi = u - p.E * (u - std::atan(u));
  return p.D * std::sin(p.C * std::atan(phi)) + p.SVx;
}

double mf_force_and_gradient(const MfParams& p, double slip_ratio, MfGradient& grad) {
  const double x = slip_ratio + p.SHx;
  const double u = p.B * x;
  const double atan_u = std::atan(u);
  const double phi = u - p.E * (u - atan_u);
  const double atan_phi = std::atan(phi);
  const double theta = p.C * atan_phi;
  const double sin_t = std::sin(theta);
  const double cos_t = std::cos(theta);
  const double dF_dphi = p.D * cos_t * p.C / (1.0 + phi * phi);
  const double dphi_du = 1.0 - p.E * (u * u) / (1.0 + u * u);
  grad[0] = dF_dphi * dphi_du * x;    // B
  grad[1] = p.D * cos_t * atan_phi;   // C
  grad[2] = sin_t;                    // D
  grad[3] = -dF_dphi * (u - atan_u);  // E
  grad[4] = dF_dphi * dphi_du * p.B;  // SHx
  grad[5] = 1.0;                      // SVx
  return p.D * sin_t + p.SVx;
}

MfPeak mf_peak(const MfParams& p, double slip_max) {
  constexpr int kScan = 400;
  int best = 0;
  double best_f = mf_force_n(p, 0.0);
  for (int i = 1; i <= kScan; ++i) {
    const double f = mf_force_n(p, slip_max * i / kScan);
    if (f > best_f) {
      best_f = f;
      best = i;
    }
  }
  double lo = slip_max * std::max(0, best - 1) / kScan;
  double hi = slip_max * std::min(kScan, best + 1) / kScan;
  const double g = (std::sqrt(5.0) - 1.0) / 2.0;
  for (int it = 0; it < 60 && hi - lo > 1e-12; ++it) {
    const double a = hi - g * (hi - lo);
    const double b = lo + g * (hi - lo);
    if (mf_force_n(p, a) > mf_force_n(p, b)) {
      hi = b;
    } else {
      lo = a;
    }
  }
  MfPeak peak;
  peak.slip_ratio = 0.5 * (lo + hi);
  peak.force_n = mf_force_n(p, peak.slip_ratio);
  if (best_f > peak.force_n) {  // the scan point was better (flat or edge maximum)
    peak.slip_ratio = slip_max * best / kScan;
    peak.force_n = best_f;
  }
  peak.interior = best > 0 && best < kScan;
  return peak;
}

std::array<double, kMfParamCount> to_array(const MfParams& p) {
  return {p.B, p.C, p.D, p.E, p.SHx, p.SVx};
}

MfParams from_array(std::span<const double> a) {
  MfParams p;
  p.B = a[0];
  p.C = a[1];
  p.D = a[2];
  p.E = a[3];
  if (a.size() > 4) p.SHx = a[4];
  if (a.size() > 5) p.SVx = a[5];
  return p;
}

}  // namespace brakefit
