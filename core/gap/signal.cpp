// Signal helpers of the conditioning: zero-phase Savitzky-Golay smoothing, its noise gain, the
// noise a channel keeps after it, derivatives and interpolation.
#include <algorithm>
#include <cmath>

#include "core/gap/internal.hpp"

namespace brakefit::gap {
namespace {

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

std::vector<double> sampler_clock(const std::vector<double>& stamps_s, int half_window) {
  const std::size_t n = stamps_s.size();
  auto smoothed = [&] {
    std::vector<double> t = smooth(stamps_s, half_window);
    for (std::size_t i = 1; i < n; ++i) t[i] = std::max(t[i], t[i - 1]);
    return t;
  };
  if (n < 8) return smoothed();
  // Least squares line of the stamps over the sample index.
  const double mean_k = 0.5 * static_cast<double>(n - 1);
  double mean_t = 0;
  for (double t : stamps_s) mean_t += t / static_cast<double>(n);
  double skt = 0, skk = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const double dk = static_cast<double>(k) - mean_k;
    skt += dk * (stamps_s[k] - mean_t);
    skk += dk * dk;
  }
  const double interval_s = skt / skk;
  if (!(interval_s > 0)) return smoothed();
  std::vector<double> line(n);
  for (std::size_t k = 0; k < n; ++k)
    line[k] = mean_t + interval_s * (static_cast<double>(k) - mean_k);
  // Regular: the residual is the stamps' scatter, with no trend (a drifting or uneven sampler, a
  // dropped sample's step of one interval): its mean over each block of six smoothers' half
  // windows stays within a quarter interval (the scatter's own, 0.4 ms over 60 samples: 0.05 ms).
  const std::size_t block = std::max<std::size_t>(8, 6 * static_cast<std::size_t>(half_window));
  for (std::size_t b0 = 0; b0 < n; b0 += block) {
    const std::size_t b1 = n - b0 < 2 * block ? n : b0 + block;  // the remainder joins the last
    double mean = 0;
    for (std::size_t k = b0; k < b1; ++k)
      mean += (stamps_s[k] - line[k]) / static_cast<double>(b1 - b0);
    if (std::abs(mean) > 0.25 * interval_s) return smoothed();
    if (b1 == n) break;
  }
  return line;
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
