// Conditioning: a brake event becomes a Run for the diagnosis (signed Eq. 1 slip, channel
// alignment, zero-phase smoothing, derivatives, noise, cuts at the runaway and a locked wheel,
// the start state, decimation).
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/curve.hpp"
#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"

namespace brakefit::gap {

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

namespace {

/// Least-squares line through the samples of the first window_s of a run.
struct StartLine {
  double at_start = 0.0, slope = 0.0;
  int points = 0;
};
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

}  // namespace

/// The initial slip rate is fitted over this much of the run's start.
constexpr double kInitialWindowS = 0.04;
/// Past this slip the wheel is taken as locked.
constexpr double kLockSlip = 0.9;
/// A lock-up runaway starts past the linear region: jumps below this slip are noise. (2 %: a
/// wheel capped by the cradle below its peak runs away from there.)
constexpr double kRunawayMinSlip = 0.02;

Run condition(const std::string& name, const pipeline::Event& e, const pipeline::Calibration& c,
              const ConditionOptions& o) {
  Run full;
  full.name = name;
  full.bench = c.bench;
  full.wheel_radius_m = c.wheel_radius_m;
  full.brake_gain_n_per_bar = c.brake_gain_n_per_bar;
  std::vector<double> v_wheel, pressure;
  for (const auto& s : e.samples) {
    if (s.v_ref_mps < 0.3) continue;
    const double f = o.force == pipeline::ForceSource::Tester
                         ? s.force_n
                         : c.brake_gain_n_per_bar * s.pressure_bar;
    if (!std::isfinite(f)) continue;
    full.t_s.push_back(static_cast<double>(s.t_ns - e.t_start_ns) * 1e-9);
    full.v_ref_mps.push_back(s.v_ref_mps);
    v_wheel.push_back(s.v_wheel_mps);
    pressure.push_back(s.pressure_bar);
    full.force_n.push_back(f);
  }
  // The lock-up runaway: past the peak a wheel can lose speed within one or two frames. There the
  // slip is measured across a single frame and the force is dominated by the wheel's deceleration
  // (I a / R^2, a numerical derivative of a step): not quasi-static data. The run is cut where
  // the slip first jumps by more than runaway_slip_per_sample between two samples.
  // A locked wheel is cut as well: the rim is held by the brake, I w' = F R - Tb no longer holds.
  {
    for (std::size_t i = 1; i < v_wheel.size(); ++i) {
      const double s0 = 1.0 - v_wheel[i - 1] / full.v_ref_mps[i - 1];
      const double s1 = 1.0 - v_wheel[i] / full.v_ref_mps[i];
      const bool runaway = o.runaway_slip_per_sample > 0 && s0 > kRunawayMinSlip &&
                           s1 - s0 > o.runaway_slip_per_sample;
      if (runaway || s1 >= kLockSlip) {
        full.runaway = runaway;
        full.runaway_force_n = full.force_n[i - 1];
        full.t_s.resize(i);
        full.v_ref_mps.resize(i);
        v_wheel.resize(i);
        pressure.resize(i);
        full.force_n.resize(i);
        break;
      }
    }
  }
  if (full.t_s.size() < 20)
    throw InputError(fmt::format("{}: too few samples for a diagnosis", name));
  // Noise of the force channel: robust scale of second differences (the signal is smooth at
  // 1 kHz; first differences would count a 250 bar/s ramp, 16 N per sample, as noise).
  std::vector<double> df;
  for (std::size_t i = 1; i + 1 < full.force_n.size(); ++i)
    df.push_back(std::abs(full.force_n[i + 1] - 2 * full.force_n[i] + full.force_n[i - 1]));
  std::nth_element(df.begin(), df.begin() + static_cast<long>(df.size() / 2), df.end());
  full.noise_n = df[df.size() / 2] / 0.6745 / std::sqrt(6.0);
  // Channel alignment: an encoder speed is the mean over the interval since the previous edge
  // time (one frame), so it describes the moment half a frame before its stamp, while the
  // pressure is sampled at the stamp. The speeds are moved forward by half the median interval.
  {
    std::vector<double> dts;
    for (std::size_t i = 1; i < full.t_s.size(); ++i) dts.push_back(full.t_s[i] - full.t_s[i - 1]);
    std::nth_element(dts.begin(), dts.begin() + static_cast<long>(dts.size() / 2), dts.end());
    const double half = 0.5 * dts[dts.size() / 2];
    auto align = [&](std::vector<double>& v) {
      std::vector<double> a(v.size());
      for (std::size_t i = 0; i + 1 < v.size(); ++i) a[i] = interp(full.t_s, v, full.t_s[i] + half);
      const std::size_t n = v.size();  // the last sample: extrapolated along the last interval
      a[n - 1] = v[n - 1] +
                 (v[n - 1] - v[n - 2]) * half / std::max(full.t_s[n - 1] - full.t_s[n - 2], 1e-9);
      v = std::move(a);
    };
    align(full.v_ref_mps);
    align(v_wheel);
  }
  const auto vr = smooth(full.v_ref_mps, o.smooth_half_window),
             vw = smooth(v_wheel, o.smooth_half_window);
  full.v_ref_mps = vr;
  for (std::size_t i = 0; i < vr.size(); ++i)
    full.slip.push_back(std::clamp(1.0 - vw[i] / vr[i], -1.0, 1.0));  // below 0: a slip offset
  full.wheel_accel_mps2 = derivative(full.t_s, vw);
  auto dref = derivative(full.t_s, vr);
  for (double& d : dref) d = -d;
  full.ref_decel_mps2 = dref;
  full.pressure_rate_bar_per_s = derivative(full.t_s, smooth(pressure, o.smooth_half_window));
  // Start state: the slip rate (a line through the first kInitialWindowS) and the force at the
  // first sample (a line through the first 20 ms: a 250 bar/s ramp adds 170 N in 10 ms, so a mean
  // would sit half of that too high).
  if (const StartLine slip = start_line(full.t_s, full.slip, kInitialWindowS); slip.points >= 3)
    full.initial_slip_rate_per_s = std::max(0.0, slip.slope);
  full.initial_force_n = start_line(full.t_s, full.force_n, 0.02).at_start;
  // Decimate uniformly in time. (Uniform in slip progress was tried: it over-weights the runaway
  // after the peak, where slip is measured across only one or two frames, and the null case got
  // worse: 147 N instead of 7 N.)
  const std::size_t n = full.t_s.size();
  if (n <= o.max_points) return full;
  std::vector<std::size_t> idx;
  for (std::size_t k = 0; k < o.max_points; ++k) idx.push_back(k * (n - 1) / (o.max_points - 1));
  Run r;
  r.name = full.name;
  r.bench = full.bench;
  r.wheel_radius_m = full.wheel_radius_m;
  r.brake_gain_n_per_bar = full.brake_gain_n_per_bar;
  r.noise_n = full.noise_n;
  r.initial_slip_rate_per_s = full.initial_slip_rate_per_s;
  r.initial_force_n = full.initial_force_n;
  r.runaway = full.runaway;
  r.runaway_force_n = full.runaway_force_n;
  for (std::size_t i : idx) {
    r.t_s.push_back(full.t_s[i]);
    r.slip.push_back(full.slip[i]);
    r.v_ref_mps.push_back(full.v_ref_mps[i]);
    r.force_n.push_back(full.force_n[i]);
    r.wheel_accel_mps2.push_back(full.wheel_accel_mps2[i]);
    r.ref_decel_mps2.push_back(full.ref_decel_mps2[i]);
    r.pressure_rate_bar_per_s.push_back(full.pressure_rate_bar_per_s[i]);
  }
  return r;
}

}  // namespace brakefit::gap
