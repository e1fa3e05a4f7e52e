// The regressions an encoder ripple is estimated by (ripple_fit.hpp).
#include "core/gap/ripple_fit.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

namespace brakefit::gap {

namespace {
/// Phases scanned around the circle for a short run (5 degrees apart).
constexpr int kPhaseSteps = 72;
}  // namespace

/// An encoder's ripple columns: the model's force answer to a slip ripple (1 - s) cos and sin
/// of the encoder's angle (times frequency_scale), the reference's with the opposite sign. The
/// ripple is in the measured slip, the residual in the force: the model passes the ripple as it
/// passes the slip, by central differences of predict. On the baseline that is K (1 - s) cos,
/// through a filtered force channel's filter (at 15 Hz, a fifth wheel at 70 km/h, a 19 ms filter
/// passes half of it, 60 degrees late); a relaxing tyre passes it late and smaller too (sigma / V
/// 0.23 s against a wheel's 1.2 s revolution at 5 km/h: 0.65 of it, 49 degrees late; read as the
/// baseline's K (1 - s), a generator B relaxation set's refit with the ripple estimated again
/// left 36 N against a 6.6 N floor, 9.8 N before it). The filter is applied to the unfiltered
/// answer from a steady start: the ripple was there before the run's first point (predict pins
/// the filter's state there to the measured force, which would hide the ripple's first tau).
ColumnPair ripple_columns(const Run& r, const RippleModel& m, std::size_t e,
                          double frequency_scale) {
  const std::size_t n = r.t_s.size();
  const double sign = e == 0 ? 1.0 : -1.0;
  constexpr double kH = 1e-5;  // slip
  // At the revolution rate the wave as the smoother passed it; the neighbouring rates of the
  // narrow-band check are read unsmoothed.
  const Run::Wave at_rate =
      frequency_scale == 1.0
          ? encoder_wave(r, e)
          : unsmoothed_wave(e == 0 ? r.wheel_angle_rad : r.ref_angle_rad, frequency_scale);
  auto answer = [&](const std::vector<double>& wave) {
    Run up = r, down = r;
    up.pressure_filter_s = down.pressure_filter_s = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double d = kH * sign * (1 - r.slip[i]) * wave[i];
      up.slip[i] += d;
      down.slip[i] -= d;
    }
    const auto fu = predict(up, m.params, m.effects), fd = predict(down, m.params, m.effects);
    std::vector<double> col(n);
    for (std::size_t i = 0; i < n; ++i) col[i] = (fu[i] - fd[i]) / (2 * kH);
    if (r.pressure_filter_s > 0) filter_first_order(r.t_s, col, r.pressure_filter_s, col.front());
    return col;
  };
  return {answer(at_rate.cos), answer(at_rate.sin)};
}

const ColumnPair& RunColumns::at(std::size_t e, double frequency_scale) {
  const auto key = std::pair{e, frequency_scale};
  auto it = cache_.find(key);
  if (it == cache_.end())
    it = cache_.emplace(key, ripple_columns(r_, m_, e, frequency_scale)).first;
  return it->second;
}

RippleFit fit_ripple(RunColumns& columns, const std::vector<double>& y, std::array<bool, 2> use,
                     int trend, std::array<double, 2> frequency_scale) {
  const Run& r = columns.run();
  RippleFit out;
  const std::size_t n = r.t_s.size();
  const int enc = static_cast<int>(use[0]) + static_cast<int>(use[1]);
  const Eigen::Index cols = trend + 1 + 2 * enc;
  Eigen::MatrixXd a(static_cast<Eigen::Index>(n), cols);
  Eigen::VectorXd b(static_cast<Eigen::Index>(n));
  const double t_end = std::max(r.t_s.back(), 1e-6);
  for (std::size_t i = 0; i < n; ++i) {
    const auto row = static_cast<Eigen::Index>(i);
    const double u = r.t_s[i] / t_end;
    double p = 1;
    for (int k = 0; k <= trend; ++k, p *= u) a(row, k) = p;
    b(row) = y[i];
  }
  Eigen::Index c = trend + 1;
  for (std::size_t e = 0; e < 2; ++e) {
    if (!use[e]) continue;
    const auto& [cos_col, sin_col] = columns.at(e, frequency_scale[e]);
    for (std::size_t i = 0; i < n; ++i) {
      a(static_cast<Eigen::Index>(i), c) = cos_col[i];
      a(static_cast<Eigen::Index>(i), c + 1) = sin_col[i];
    }
    c += 2;
  }
  const Eigen::VectorXd x = a.colPivHouseholderQr().solve(b);
  const Eigen::VectorXd res = b - a * x;
  out.ssr = res.squaredNorm();
  const double s2 =
      res.squaredNorm() / std::max(1.0, static_cast<double>(n) - static_cast<double>(cols));
  const Eigen::MatrixXd cov = s2 * (a.transpose() * a).inverse();
  c = trend + 1;
  for (std::size_t e = 0; e < 2; ++e) {
    if (!use[e]) continue;
    out.used[e] = true;
    out.c[e] = x(c);
    out.s[e] = x(c + 1);
    out.se[e] = std::sqrt(0.5 * (cov(c, c) + cov(c + 1, c + 1)));
    c += 2;
  }
  return out;
}

std::optional<std::array<double, 2>> scan_phase(RunColumns& columns, const std::vector<double>& y,
                                                std::size_t e, double amplitude) {
  const Run& r = columns.run();
  const std::size_t n = r.t_s.size();
  // The free fit's columns, residualised on the trend: SSR(c, s) is then a quadratic form.
  Eigen::MatrixXd trend(static_cast<Eigen::Index>(n), 2), cols(static_cast<Eigen::Index>(n), 3);
  const double t_end = std::max(r.t_s.back(), 1e-6);
  const auto& [cos_col, sin_col] = columns.at(e, 1.0);
  for (std::size_t i = 0; i < n; ++i) {
    const auto row = static_cast<Eigen::Index>(i);
    trend(row, 0) = 1;
    trend(row, 1) = r.t_s[i] / t_end;
    cols(row, 0) = y[i];
    cols(row, 1) = cos_col[i];
    cols(row, 2) = sin_col[i];
  }
  const Eigen::MatrixXd res = cols - trend * trend.colPivHouseholderQr().solve(cols);
  const Eigen::MatrixXd g = res.transpose() * res;  // y, C, S inner products
  double best = g(0, 0), best_c = 0, best_s = 0;
  for (int k = 0; k < kPhaseSteps; ++k) {
    const double phi = 2 * M_PI * k / kPhaseSteps;
    const double c = amplitude * std::cos(phi), s = amplitude * std::sin(phi);
    const double ssr = g(0, 0) - 2 * c * g(0, 1) - 2 * s * g(0, 2) + c * c * g(1, 1) +
                       2 * c * s * g(1, 2) + s * s * g(2, 2);
    if (ssr < best) {
      best = ssr;
      best_c = c;
      best_s = s;
    }
  }
  if (best_c == 0 && best_s == 0) return std::nullopt;
  return std::array<double, 2>{best_c, best_s};
}

}  // namespace brakefit::gap
