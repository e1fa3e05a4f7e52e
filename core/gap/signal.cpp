// Signal helpers of the conditioning: zero-phase Savitzky-Golay smoothing, its noise gain, the
// noise a channel keeps after it, derivatives and interpolation.
#include <algorithm>
#include <cmath>
#include <optional>

#include "core/gap/internal.hpp"

namespace brakefit::gap {

namespace {

/// How many standard errors of the stamps' fitted interval a whole number of milliseconds may lie
/// from it and be taken as the sampler's interval (sampler_clock).
constexpr double kWholeMsSe = 3.0;

/// The centre weights of the quadratic Savitzky-Golay filter of half window m, k = -m..m.
std::vector<double> sg_weights(int half_window) {
  const double m = half_window;
  const double norm = (2 * m - 1) * (2 * m + 1) * (2 * m + 3);
  std::vector<double> w;
  for (int k = -half_window; k <= half_window; ++k)
    w.push_back((3 * (3 * m * m + 3 * m - 1) - 15.0 * k * k) / norm);
  return w;
}

}  // namespace

std::optional<double> smoothed_noise_sd(const std::vector<double>& x, int half_window) {
  // The difference of the smoother and one three times as wide: both keep a quadratic, so the
  // signal cancels but for its third and higher derivatives, and the noise's share of it is
  // known for white noise (wa.wa - 2 wa.wb + wb.wb). Scaled to the smoother's own share
  // (wa.wa), it is the noise the smoother leaves, whatever the noise's correlation: white noise,
  // the anti-correlated error of edge-timed frame means (consecutive frames share an edge) and
  // the correlated error of a rebuilt staircase each count as what they leave.
  const int wide = 3 * half_window;
  if (half_window <= 0) return 0.0;
  if (x.size() < 4 * static_cast<std::size_t>(wide) + 10) return std::nullopt;
  const auto a = smooth(x, half_window), b = smooth(x, wide);
  std::vector<double> d;
  for (std::size_t i = static_cast<std::size_t>(wide);
       i + static_cast<std::size_t>(wide) < x.size(); ++i)
    d.push_back(a[i] - b[i]);
  std::vector<double> dev = d;
  const double med = upper_median(dev);
  for (double& v : dev) v = std::abs(v - med);
  const double sd_d = upper_median(dev) / 0.6745;
  const auto wa = sg_weights(half_window), wb = sg_weights(wide);
  double aa = 0, ab = 0, bb = 0;
  for (double w : wa) aa += w * w;
  for (double w : wb) bb += w * w;
  for (std::size_t k = 0; k < wa.size(); ++k)  // wa's k-th weight sits at wide - half_window + k
    ab += wa[k] * wb[k + static_cast<std::size_t>(wide - half_window)];
  return sd_d * std::sqrt(aa / std::max(aa - 2 * ab + bb, 1e-12));
}

std::vector<double> smooth(const std::vector<double>& x, int hw) {
  // Zero-phase Savitzky-Golay (quadratic, centred, no lag; the window shrinks at the ends). A
  // moving average would bias the slip where it curves: near the peak of a 250 bar/s stop the
  // slip accelerates within the window.
  std::vector<double> y(x.size());
  const auto n = static_cast<long>(x.size());
  for (long i = 0; i < n; ++i) {
    const long w = std::min<long>({hw, i, n - 1 - i});
    if (w == 0) {
      y[static_cast<std::size_t>(i)] = x[static_cast<std::size_t>(i)];
      continue;
    }
    const double m = static_cast<double>(w);
    const double norm = (2 * m - 1) * (2 * m + 1) * (2 * m + 3);
    double s = 0;
    for (long k = -w; k <= w; ++k) {
      const double kk = static_cast<double>(k);
      s += (3 * (3 * m * m + 3 * m - 1) - 15 * kk * kk) / norm * x[static_cast<std::size_t>(i + k)];
    }
    y[static_cast<std::size_t>(i)] = s;
  }
  return y;
}

namespace {

/// The stamps' least-squares line over the sample index: its centre, slope and slope's standard
/// error (infinite under 8 stamps: too few to read it on).
struct StampLine {
  double mean_k = 0, mean_t_s = 0, interval_s = 0, interval_se_s = 0;
  double at(std::size_t k) const {
    return mean_t_s + interval_s * (static_cast<double>(k) - mean_k);
  }
};

StampLine stamp_line(const std::vector<double>& stamps_s) {
  const std::size_t n = stamps_s.size();
  StampLine l;
  l.mean_k = 0.5 * static_cast<double>(n - 1);
  for (double t : stamps_s) l.mean_t_s += t / static_cast<double>(n);
  double skt = 0, skk = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const double dk = static_cast<double>(k) - l.mean_k;
    skt += dk * (stamps_s[k] - l.mean_t_s);
    skk += dk * dk;
  }
  l.interval_s = skt / skk;
  double res_sq = 0;
  for (std::size_t k = 0; k < n; ++k) res_sq += (stamps_s[k] - l.at(k)) * (stamps_s[k] - l.at(k));
  l.interval_se_s = n < 8 ? INFINITY : std::sqrt(res_sq / static_cast<double>(n - 2) / skk);
  return l;
}

/// Regular: the residual is the stamps' scatter, with no trend (a drifting or uneven sampler, a
/// dropped sample's step of one interval): its mean over each block of six smoothers' half
/// windows stays within a quarter interval (the scatter's own, 0.4 ms over 60 samples: 0.05 ms).
bool regular(const std::vector<double>& stamps_s, const StampLine& l, int half_window) {
  const std::size_t n = stamps_s.size();
  const std::size_t block = std::max<std::size_t>(8, 6 * static_cast<std::size_t>(half_window));
  for (std::size_t b0 = 0; b0 < n; b0 += block) {
    const std::size_t b1 = n - b0 < 2 * block ? n : b0 + block;  // the remainder joins the last
    double mean = 0;
    for (std::size_t k = b0; k < b1; ++k)
      mean += (stamps_s[k] - l.at(k)) / static_cast<double>(b1 - b0);
    if (std::abs(mean) > 0.25 * l.interval_s) return false;
    if (b1 == n) break;
  }
  return true;
}

}  // namespace

std::optional<SamplerInterval> sampler_interval(const std::vector<double>& stamps_s,
                                                int half_window) {
  if (stamps_s.size() < 8) return std::nullopt;
  const StampLine l = stamp_line(stamps_s);
  if (!(l.interval_s > 0) || !regular(stamps_s, l, half_window)) return std::nullopt;
  return SamplerInterval{l.interval_s, l.interval_se_s};
}

std::vector<double> sampler_clock(const std::vector<double>& stamps_s, int half_window,
                                  std::optional<SamplerInterval> event) {
  const std::size_t n = stamps_s.size();
  auto smoothed = [&] {
    std::vector<double> t = smooth(stamps_s, half_window);
    for (std::size_t i = 1; i < n; ++i) t[i] = std::max(t[i], t[i - 1]);
    return t;
  };
  if (n < 8 && !event) return smoothed();
  StampLine l = stamp_line(stamps_s);
  // The event's interval where it is the better read (more stamps; the run's own scatter).
  if (event && (!(l.interval_s > 0) || event->se_s < l.interval_se_s)) {
    l.interval_s = event->interval_s;
    l.interval_se_s = event->se_s;
  }
  // A tester's sampler ticks on a millisecond timer: where one whole number of milliseconds lies
  // within kWholeMsSe standard errors of the interval (and no other can), it is that number.
  const double whole_s = std::round(l.interval_s * 1e3) / 1e3;
  const double tol_s = kWholeMsSe * l.interval_se_s;
  if (whole_s >= 1e-3 && tol_s < 0.5e-3 && std::abs(l.interval_s - whole_s) <= tol_s)
    l.interval_s = whole_s;
  if (!(l.interval_s > 0) || !regular(stamps_s, l, half_window)) return smoothed();
  std::vector<double> line(n);
  for (std::size_t k = 0; k < n; ++k) line[k] = l.at(k);
  return line;
}

double median_interval_s(const std::vector<double>& t_s) {
  std::vector<double> dt;
  for (std::size_t i = 1; i < t_s.size(); ++i) dt.push_back(t_s[i] - t_s[i - 1]);
  return dt.empty() ? 0.0 : upper_median(dt);
}

std::vector<double> derivative(const std::vector<double>& t, const std::vector<double>& x) {
  std::vector<double> d(x.size(), 0.0);
  for (std::size_t i = 0; i < x.size(); ++i) {
    const std::size_t a = i == 0 ? 0 : i - 1, b = std::min(i + 1, x.size() - 1);
    if (t[b] > t[a]) d[i] = (x[b] - x[a]) / (t[b] - t[a]);
  }
  return d;
}

double interp(const std::vector<double>& t, const std::vector<double>& x, double at) {
  if (at <= t.front()) return x.front();
  if (at >= t.back()) return x.back();
  const auto j = static_cast<std::size_t>(std::upper_bound(t.begin(), t.end(), at) - t.begin());
  const double u = (at - t[j - 1]) / (t[j] - t[j - 1]);
  return x[j - 1] + u * (x[j] - x[j - 1]);
}

double smoothing_noise_gain(int half_window) {
  // The centre weights of the quadratic Savitzky-Golay filter: sqrt(sum w^2) = sqrt(w0).
  if (half_window <= 0) return 1.0;
  const double m = half_window;
  return std::sqrt(3 * (3 * m * m + 3 * m - 1) / ((2 * m - 1) * (2 * m + 1) * (2 * m + 3)));
}

}  // namespace brakefit::gap
