// A run's force at its first sample, the start the relaxing contact's transient slip is taken
// from. Behind a declared pressure filter the channel trails the line: a ramp the line started
// 2 ms before the run shows in the channel as a few newtons, in the line as tens, and the contact
// that relaxes from a force too low is late by all of sigma / V (a truck's 0.36 m relaxation read
// 0.29).
#include <cmath>
#include <limits>

#include "core/gap/channels.hpp"

namespace brakefit::gap {

StartLine start_line(const std::vector<double>& t_s, const std::vector<double>& x,
                     double window_s) {
  double st = 0, sx = 0, stt = 0, stx = 0;
  StartLine l;
  for (std::size_t i = 0; i < t_s.size() && t_s[i] - t_s[0] <= window_s; ++i, ++l.points) {
    const double t = t_s[i] - t_s[0];
    st += t;
    sx += x[i];
    stt += t * t;
    stx += t * x[i];
  }
  const double m = l.points, den = m * stt - st * st;
  if (den > 0) {
    l.slope = (m * stx - st * sx) / den;
    l.at_start = (sx * stt - st * stx) / den;
  } else if (l.points > 0) {
    l.at_start = sx / m;
  }
  return l;
}

namespace {

/// A line ramping at rate from t_on, seen through a first-order filter of tau: the ramp less its
/// filter's lag, r ((t - t_on) - tau (1 - exp(-(t - t_on) / tau))), zero before t_on.
double filtered_ramp(double rate, double t_on, double tau_s, double t) {
  const double u = t - t_on;
  return u > 0 ? rate * (u - tau_s * (1.0 - std::exp(-u / tau_s))) : 0.0;
}

}  // namespace

double line_force_at_start(const std::vector<double>& t_s, const std::vector<double>& force_n,
                           double filter_s) {
  const StartLine plain = start_line(t_s, force_n, kStartForceWindowS);
  if (filter_s <= 0 || t_s.empty()) return plain.at_start;
  // The ramp's rate, where the filter has settled to it (three time constants on): the channel
  // there runs parallel to the line.
  const double t0 = t_s.front(), from = t0 + 3 * filter_s;
  std::vector<double> tt, ff;
  for (std::size_t i = 0; i < t_s.size() && t_s[i] <= from + std::max(0.02, 4 * filter_s); ++i)
    if (t_s[i] >= from) {
      tt.push_back(t_s[i]);
      ff.push_back(force_n[i]);
    }
  const StartLine settled = start_line(tt, ff, std::numeric_limits<double>::infinity());
  if (settled.points < 3 || settled.slope <= 0) return plain.at_start;
  const double rate = settled.slope;
  // The ramp's onset: the one whose filtered ramp best meets the channel's first four time
  // constants (before the run's start or after it, in steps of a fiftieth of tau).
  double best_sse = std::numeric_limits<double>::infinity(), t_on = t0;
  for (int k = -500; k <= 200; ++k) {
    const double on = t0 + k * filter_s / 50.0;
    double sse = 0;
    for (std::size_t i = 0; i < t_s.size() && t_s[i] <= t0 + 4 * filter_s; ++i) {
      const double e = force_n[i] - filtered_ramp(rate, on, filter_s, t_s[i]);
      sse += e * e;
    }
    if (sse < best_sse) {
      best_sse = sse;
      t_on = on;
    }
  }
  return rate * std::max(0.0, t0 - t_on);
}

}  // namespace brakefit::gap
