// A fifth wheel's once-per-revolution ripple read from its own speed. The vehicle slows smoothly
// (its deceleration follows the line pressure), so a ripple at the fifth wheel's revolution
// stands apart from the speed's trend; read from the force residual instead, a sinusoid over two
// to nine revolutions also took part of an effect's bend (load transfer: a third of its 26 N),
// and the ripple's derivative in the deceleration (5e-4 of 19 m/s at 15 Hz is 0.6 m/s^2) was
// read as load.
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"

namespace brakefit::gap {

namespace {

/// The trend's knots are this many revolutions apart: a cubic spline so knotted passes the
/// vehicle's slowing (a deceleration that stops rising mid-run left 7 % of a 4e-4 ripple in
/// the amplitude at 1.5 revolutions, and failed the narrow-band test at 1) but bends too slowly
/// to take a once-per-revolution ripple.
constexpr double kKnotRevolutions = 0.75;
/// At its revolution rate the ripple must explain more than a sinusoid at half or twice the
/// rate explains (a trend left in the speed is broad-band, a ripple narrow). Over 2-3
/// revolutions those neighbours take much of a true ripple's projection (generator B's nulls:
/// 0.8-0.9 of it), so no wider margin is asked; the 3 standard errors carry the weight.
constexpr double kSpeedNarrowBand = 1.0;
/// A run that did not find the ripple itself places the shared one when it spans this many
/// revolutions.
constexpr double kSharedRippleRevolutions = 1.0;
/// A run's own amplitude is taken as read over this many revolutions; over fewer it must agree
/// with the other runs' within kRippleAgreement (one encoder, one eccentricity).
constexpr double kConfirmedRippleRevolutions = 4.0;
constexpr double kRippleAgreement = 0.3;
constexpr int kPhaseSteps = 72;

struct SpeedFit {
  double c = 0, s = 0, se = 0;
  double explained = 0;  ///< residual sum of squares the ripple columns remove beyond the trend
};

/// The speed's trend: a cubic spline in the rolled angle (truncated powers, knots
/// kKnotRevolutions apart), one row per point.
Eigen::MatrixXd trend_basis(const std::vector<double>& angle) {
  const std::size_t n = angle.size();
  const double span = std::max(angle.back(), 1e-9);
  const int intervals = std::max(1, static_cast<int>(span / (2 * M_PI * kKnotRevolutions)));
  Eigen::MatrixXd a(static_cast<Eigen::Index>(n), 4 + (intervals - 1));
  for (std::size_t i = 0; i < n; ++i) {
    const auto row = static_cast<Eigen::Index>(i);
    const double u = angle[i] / span;
    a(row, 0) = 1;
    a(row, 1) = u;
    a(row, 2) = u * u;
    a(row, 3) = u * u * u;
    for (int k = 1; k < intervals; ++k) {
      const double d = std::max(0.0, u - static_cast<double>(k) / intervals);
      a(row, 3 + k) = d * d * d;
    }
  }
  return a;
}

/// Least squares of the speed on the trend and v cos, v sin of the angle times frequency_scale.
SpeedFit fit_speed(const std::vector<double>& v, const std::vector<double>& angle,
                   double frequency_scale) {
  const std::size_t n = v.size();
  const Eigen::MatrixXd trend = trend_basis(angle);
  const Eigen::Index trend_cols = trend.cols();
  Eigen::MatrixXd a(static_cast<Eigen::Index>(n), trend_cols + 2);
  a.leftCols(trend_cols) = trend;
  Eigen::VectorXd b(static_cast<Eigen::Index>(n));
  for (std::size_t i = 0; i < n; ++i) {
    const auto row = static_cast<Eigen::Index>(i);
    a(row, trend_cols) = v[i] * std::cos(frequency_scale * angle[i]);
    a(row, trend_cols + 1) = v[i] * std::sin(frequency_scale * angle[i]);
    b(row) = v[i];
  }
  const auto qr = a.colPivHouseholderQr();
  const Eigen::VectorXd x = qr.solve(b);
  const double ssr = (b - a * x).squaredNorm();
  const double ssr_trend = (b - trend * trend.colPivHouseholderQr().solve(b)).squaredNorm();
  SpeedFit out;
  out.c = x(trend_cols);
  out.s = x(trend_cols + 1);
  out.explained = ssr_trend - ssr;
  const double s2 = ssr / std::max(1.0, static_cast<double>(n) - static_cast<double>(a.cols()));
  const Eigen::MatrixXd cov = s2 * (a.transpose() * a).inverse();
  out.se = std::sqrt(0.5 * (cov(trend_cols, trend_cols) + cov(trend_cols + 1, trend_cols + 1)));
  return out;
}

/// The speed read as v (1 + c cos + s sin of the angle, as the wave carries it), with that
/// ripple divided out.
std::vector<double> without_ripple(const std::vector<double>& v, const Run::Wave& wave, double c,
                                   double s) {
  std::vector<double> out(v.size());
  for (std::size_t i = 0; i < v.size(); ++i)
    out[i] = v[i] / (1.0 + c * wave.cos[i] + s * wave.sin[i]);
  return out;
}

double median_of(std::vector<double> x) {
  // Of two, their mean: the larger alone was a 30 km/h run's trend misfit, 10x.
  std::sort(x.begin(), x.end());
  const std::size_t mid = x.size() / 2;
  return x.size() % 2 == 1 ? x[mid] : 0.5 * (x[mid - 1] + x[mid]);
}

/// The phase of a ripple of amplitude amp in the speed v, scanned with the trend refitted at
/// each; its c and s, or nothing where no phase explains at least half of what a ripple of
/// that amplitude and phase can over the run (its own variance beyond the trend: over two
/// revolutions the spline takes a third of a ripple's; against its whole variance a 30 km/h
/// run never placed a true one, and its slip noise then carried it), not just a sliver of a
/// trend's misfit.
std::optional<std::pair<double, double>> place_phase(const std::vector<double>& v,
                                                     const std::vector<double>& angle,
                                                     const Run::Wave& wave, double amp) {
  const std::size_t n = v.size();
  const Eigen::MatrixXd a = trend_basis(angle);
  const auto qr = a.colPivHouseholderQr();
  auto ssr = [&](double c, double s) {
    const std::vector<double> w = without_ripple(v, wave, c, s);
    const Eigen::Map<const Eigen::VectorXd> b(w.data(), static_cast<Eigen::Index>(n));
    return (b - a * qr.solve(b)).squaredNorm();
  };
  const double none = ssr(0, 0);
  double best = none, best_c = 0, best_s = 0;
  for (int k = 0; k < kPhaseSteps; ++k) {
    const double phi = 2 * M_PI * k / kPhaseSteps, c = amp * std::cos(phi), s = amp * std::sin(phi);
    if (const double e = ssr(c, s); e < best) {
      best = e;
      best_c = c;
      best_s = s;
    }
  }
  if (best_c == 0 && best_s == 0) return std::nullopt;  // no phase explains anything
  Eigen::VectorXd ripple(static_cast<Eigen::Index>(n));
  for (std::size_t i = 0; i < n; ++i)
    ripple(static_cast<Eigen::Index>(i)) = v[i] * (best_c * wave.cos[i] + best_s * wave.sin[i]);
  const double ripple_sq = (ripple - a * qr.solve(ripple)).squaredNorm();
  if (none - best < 0.5 * ripple_sq) return std::nullopt;
  return std::pair{best_c, best_s};
}

}  // namespace

std::optional<ReferenceRipple> fifth_wheel_ripple(const std::vector<double>& t_s,
                                                  const std::vector<double>& v_mps,
                                                  double radius_m) {
  const std::size_t n = t_s.size();
  if (n < 50 || v_mps.size() != n || radius_m <= 0) return std::nullopt;
  std::vector<double> angle(n, 0.0);
  for (std::size_t i = 1; i < n; ++i)
    angle[i] = angle[i - 1] + 0.5 * (v_mps[i] + v_mps[i - 1]) * (t_s[i] - t_s[i - 1]) / radius_m;
  ReferenceRipple out;
  out.revolutions = angle.back() / (2 * M_PI);
  if (out.revolutions < kReferenceRippleRevolutions) return std::nullopt;
  const SpeedFit at = fit_speed(v_mps, angle, 1.0);
  const double neighbours =
      std::max(fit_speed(v_mps, angle, 0.5).explained, fit_speed(v_mps, angle, 2.0).explained);
  out.amplitude = std::hypot(at.c, at.s);
  out.found = out.amplitude > 3 * at.se && at.explained > kSpeedNarrowBand * neighbours &&
              out.amplitude < 0.01;
  if (!out.found) return out;
  out.c = at.c;
  out.s = at.s;
  out.v_mps = without_ripple(v_mps, unsmoothed_wave(angle), at.c, at.s);
  return out;
}

std::string share_fifth_wheel_ripple(std::vector<Run>& runs) {
  std::vector<double> amps;
  for (const Run& r : runs)
    if (r.ref_ripple_amplitude > 0) amps.push_back(r.ref_ripple_amplitude);
  if (amps.empty()) return {};
  const double amp = median_of(amps);
  // A run that read its own amplitude over few revolutions and disagrees with the others' is
  // placed at theirs: over 2.5 revolutions the spline's misfit still reached 1.6x the encoder's
  // amplitude (generator B's ground, a 30 km/h run: 5.5e-4 beside 3.4e-4 and 3.3e-4 over 6 and
  // 10 revolutions), and its remainder, 15 N against the tyre's slope, was left in that run.
  int replaced = 0;
  for (Run& r : runs) {
    if (r.ref_ripple_amplitude <= 0 || r.ref_angle_rad.empty() ||
        r.ref_angle_rad.back() >= 2 * M_PI * kConfirmedRippleRevolutions)
      continue;
    std::vector<double> others;
    for (const Run& o : runs)
      if (&o != &r && o.ref_ripple_amplitude > 0) others.push_back(o.ref_ripple_amplitude);
    if (others.empty()) continue;
    const double theirs = median_of(others);
    if (std::abs(r.ref_ripple_amplitude / theirs - 1) <= kRippleAgreement) continue;
    // The speed with its own estimate multiplied back in, the phase scanned at theirs (the
    // run's speed is smoothed: its ripple is the wave the smoother passed).
    const Run::Wave wave = encoder_wave(r, 1);
    std::vector<double> v = r.v_ref_mps;
    for (std::size_t i = 0; i < v.size(); ++i)
      v[i] *= 1.0 + r.ref_ripple_c * wave.cos[i] + r.ref_ripple_s * wave.sin[i];
    const auto placed = place_phase(v, r.ref_angle_rad, wave, theirs);
    if (!placed) continue;
    // The slip, the deceleration and the noise probe carry the own estimate's removal: the
    // difference is taken out (first order in the ripple, as its removal is).
    take_out_reference_ripple(r, placed->first - r.ref_ripple_c, placed->second - r.ref_ripple_s);
    r.v_ref_mps = without_ripple(v, wave, placed->first, placed->second);
    r.ref_ripple_amplitude = theirs;
    r.ref_ripple_c = placed->first;
    r.ref_ripple_s = placed->second;
    ++replaced;
  }
  int placed = 0, looked = 0;
  for (Run& r : runs) {
    const std::size_t n = r.t_s.size();
    if (r.ref_ripple_amplitude > 0 || n < 30 || r.ref_angle_rad.size() != n ||
        r.v_ref_mps.size() != n)
      continue;
    if (r.ref_angle_rad.back() < 2 * M_PI * kSharedRippleRevolutions) continue;
    ++looked;
    const Run::Wave wave = encoder_wave(r, 1);
    const auto cs = place_phase(r.v_ref_mps, r.ref_angle_rad, wave, amp);
    if (!cs) continue;
    r.v_ref_mps = without_ripple(r.v_ref_mps, wave, cs->first, cs->second);
    take_out_reference_ripple(r, cs->first, cs->second);
    r.ref_ripple_amplitude = amp;
    r.ref_ripple_c = cs->first;
    r.ref_ripple_s = cs->second;
    r.ref_ripple_from_speed = true;
    ++placed;
  }
  // Where it could not be placed it stays in the run: its slip noise carries it (the RMS of the
  // smoothed wave at that amplitude, times 1 - s), so the floor is honest about it, as for the
  // residual's estimate.
  int found = 0;
  for (Run& r : runs) {
    found += r.ref_ripple_amplitude > 0 ? 1 : 0;
    if (r.ref_ripple_amplitude > 0) continue;
    const Run::Wave wave = encoder_wave(r, 1);
    for (std::size_t i = 0; i < r.slip_sd.size() && i < r.slip.size(); ++i)
      r.slip_sd[i] = std::hypot(r.slip_sd[i], amp * wave_rms(wave, i) * (1 - r.slip[i]));
  }
  std::string out = fmt::format(
      "the fifth wheel's ripple (once per revolution) was read from its own speed and taken out "
      "of the slip and the deceleration in {} of {} runs (amplitude {:.2g})",
      found, runs.size(), amp);
  if (looked > 0)
    out += fmt::format("; {} of {} shorter runs took that amplitude and placed its phase", placed,
                       looked);
  if (replaced > 0)
    out += fmt::format(
        "; {} run{} whose own amplitude, read over fewer than {:g} revolutions, differed from the "
        "others' by more than {:.0f} % took theirs and placed its phase",
        replaced, replaced == 1 ? "" : "s", kConfirmedRippleRevolutions, 100 * kRippleAgreement);
  return out;
}

}  // namespace brakefit::gap
