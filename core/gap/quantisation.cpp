// Quantised channels (a tester's export rounds its speeds to 0.5-3 mm/s): the step found from
// the values, a channel rebuilt from its transitions, and a roller held at speed read as the
// smooth speed under its encoder's ripple.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"

namespace brakefit::gap {

/// Samples an excursion into a level must last to be shaped as a peak (see dequantise).
constexpr std::size_t kMinExcursionSamples = 4;

namespace {

/// Each anchor's slope: the derivative of the parabola through it and its neighbours, limited
/// so the curve never overshoots the anchors (Steffen 1990: flat at a turn, at most twice
/// either secant). The ends take their one secant.
std::vector<double> anchor_slopes(const std::vector<double>& at, const std::vector<double>& val) {
  const std::size_t n = at.size();
  std::vector<double> secant(n - 1), slope(n);
  for (std::size_t k = 0; k + 1 < n; ++k)
    secant[k] = (val[k + 1] - val[k]) / std::max(at[k + 1] - at[k], 1e-9);
  slope.front() = secant.front();
  slope.back() = secant.back();
  for (std::size_t k = 1; k + 1 < n; ++k) {
    const double a = secant[k - 1], b = secant[k];
    if (a * b <= 0) {
      slope[k] = 0;
      continue;
    }
    const double h0 = at[k] - at[k - 1], h1 = at[k + 1] - at[k];
    const double p = (a * h1 + b * h0) / std::max(h0 + h1, 1e-9);
    slope[k] = std::copysign(std::min({std::abs(p), 2 * std::abs(a), 2 * std::abs(b)}), a);
  }
  return slope;
}

/// The cubic through anchors k and k+1 with their slopes, at time t.
double hermite(const std::vector<double>& at, const std::vector<double>& val,
               const std::vector<double>& slope, std::size_t k, double t) {
  const double h = std::max(at[k + 1] - at[k], 1e-9), u = (t - at[k]) / h;
  const double u2 = u * u, u3 = u2 * u;
  return (2 * u3 - 3 * u2 + 1) * val[k] + (u3 - 2 * u2 + u) * h * slope[k] +
         (3 * u2 - 2 * u3) * val[k + 1] + (u3 - u2) * h * slope[k + 1];
}

}  // namespace

std::vector<double> dequantise(const std::vector<double>& t, const std::vector<double>& x,
                               double step) {
  // Anchors: where the level changes between samples i-1 and i, the signal crossed the middle of
  // the two levels, half-way in time.
  std::vector<double> at, val;
  std::vector<std::size_t> first;  // the first sample after each anchor
  for (std::size_t i = 1; i < x.size(); ++i)
    if (x[i] != x[i - 1]) {
      at.push_back(0.5 * (t[i] + t[i - 1]));
      val.push_back(0.5 * (x[i] + x[i - 1]));
      first.push_back(i);
    }
  if (at.size() < 2) return x;
  const std::size_t n = at.size();
  const std::vector<double> slope = anchor_slopes(at, val);
  std::vector<double> y(x.size());
  std::size_t seg = 0;  // the anchors' interval holding t[i] (the stamps rise)
  for (std::size_t i = 0; i < x.size(); ++i) {
    double v = 0;
    if (t[i] <= at.front()) {  // outside the anchors: along the end anchors' slopes
      v = val.front() + slope.front() * (t[i] - at.front());
    } else if (t[i] >= at.back()) {
      v = val.back() + slope.back() * (t[i] - at.back());
    } else {
      while (seg + 2 < n && at[seg + 1] < t[i]) ++seg;
      v = hermite(at, val, slope, seg, t[i]);
    }
    // The signal lies within half a step of the level it was quantised to.
    y[i] = std::clamp(v, x[i] - 0.5 * step, x[i] + 0.5 * step);
  }
  // An excursion: the signal crossed into a level and back out over the same boundary (the peak
  // of a ripple, or a trend turning). Between the two crossings the anchors say nothing but
  // "inside the level"; a straight line along the boundary would clip every peak there (an
  // encoder's ripple of about one step read 40 % too small). The peak is put at the level, the
  // middle of where it can be, on a parabola through the two crossings. (A short excursion is
  // noise dithering across the boundary and stays on it.)
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const std::size_t i0 = first[k], i1 = first[k + 1];
    if (val[k + 1] != val[k] || i1 - i0 < kMinExcursionSamples) continue;
    const double span = at[k + 1] - at[k];
    for (std::size_t i = i0; i < i1; ++i) {
      const double u = (t[i] - at[k]) / span;
      y[i] = val[k] + (x[i] - val[k]) * 4 * u * (1 - u);
    }
  }
  return y;
}

std::vector<double> rebuilt_timing_sd(const std::vector<double>& t, const std::vector<double>& y,
                                      double step) {
  std::vector<double> sd = derivative(t, y);
  const double dt = median_interval_s(t);
  for (double& d : sd) d = std::min(std::abs(d) * dt, step) / std::sqrt(12.0);
  return sd;
}

ChannelNoise channel_noise(const std::vector<double>& x) {
  ChannelNoise out;
  if (x.size() < 3) return out;
  std::vector<double> d2;
  for (std::size_t i = 1; i + 1 < x.size(); ++i)
    d2.push_back(std::abs(x[i + 1] - 2 * x[i] + x[i - 1]));
  const double random_sd = upper_median(d2) / 0.6745 / std::sqrt(6.0);
  // Quantisation: the smallest non-zero step, if (nearly) every non-zero step is a whole
  // multiple of it.
  double scale = 0;
  for (double v : x) scale = std::max(scale, std::abs(v));
  std::vector<double> steps;
  for (std::size_t i = 1; i < x.size(); ++i)
    if (const double d = std::abs(x[i] - x[i - 1]); d > 1e-12 * std::max(scale, 1.0))
      steps.push_back(d);
  if (!steps.empty()) {
    const double q = *std::min_element(steps.begin(), steps.end());
    std::size_t whole = 0;
    for (double d : steps)
      if (std::abs(d / q - std::round(d / q)) < 0.1) ++whole;
    if (static_cast<double>(whole) >= 0.9 * static_cast<double>(steps.size())) out.step = q;
  }
  out.sd = std::max(random_sd, out.step / std::sqrt(12.0));
  return out;
}

std::vector<double> held_roller_speed(const std::vector<double>& t_s, const std::vector<double>& v,
                                      double roller_radius_m) {
  // Least squares on the staircase itself: averaged over where the levels fall, a quantiser's
  // output is its input, so the staircase carries the trend and the ripple unbiased (the
  // rebuilt channel clips a ripple of about a step). Columns: a quadratic trend in time and the
  // ripple's first two harmonics at the roller's revolution (its angle from the mean speed);
  // only the trend is kept.
  const std::size_t n = t_s.size();
  if (n < 20 || roller_radius_m <= 0) return {};
  double mean = 0;
  for (double x : v) mean += x / static_cast<double>(n);
  const double span = std::max(t_s.back() - t_s.front(), 1e-6);
  const double turns = mean * span / (2 * M_PI * roller_radius_m);
  const int harmonics = turns >= kHeldRollerMinTurns ? 2 : 0;
  const Eigen::Index cols = 3 + 2 * harmonics;
  Eigen::MatrixXd a(static_cast<Eigen::Index>(n), cols);
  Eigen::VectorXd b(static_cast<Eigen::Index>(n));
  for (std::size_t i = 0; i < n; ++i) {
    const auto row = static_cast<Eigen::Index>(i);
    const double u = (t_s[i] - t_s.front()) / span,
                 ang = mean * (t_s[i] - t_s.front()) / roller_radius_m;
    a(row, 0) = 1;
    a(row, 1) = u;
    a(row, 2) = u * u;
    for (int h = 1; h <= harmonics; ++h) {
      a(row, 1 + 2 * h) = std::cos(h * ang);
      a(row, 2 + 2 * h) = std::sin(h * ang);
    }
    b(row) = v[i];
  }
  const Eigen::VectorXd x = a.colPivHouseholderQr().solve(b);
  std::vector<double> out(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double u = (t_s[i] - t_s.front()) / span;
    out[i] = x(0) + x(1) * u + x(2) * u * u;
  }
  return out;
}

}  // namespace brakefit::gap
