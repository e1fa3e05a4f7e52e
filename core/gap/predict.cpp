// The augmented model predict(): the Magic Formula with the candidate effects added
// (shared/docs/physics.md section 3), a run at a time through core/vecmath; and what it reads the
// run through (the body's pitch behind the deceleration, the tyre's relaxation, a late channel,
// the declared pressure filter).
#include <algorithm>
#include <cmath>
#include <functional>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"
#include "core/gap/predict_cache.hpp"
#include "core/vecmath.hpp"

namespace brakefit::gap {

namespace {

/// The body's pitch at the run's start: the deceleration at the run's first time from a
/// Theil-Sen line through its first kPitchStartWindowS (at least kPitchStartSamples samples).
/// The run starts from a wheel rolling free, so the body rests in pitch on the drag's
/// deceleration; the first sample's derivative is taken at the smoothed speed's edge (10 m/s^2
/// off on a 70 km/h run of generator C), and a lag started there carried it as load for
/// 0.1-0.2 s. A line, not a mean: a brake that bites at once ramps the deceleration within the
/// window (generator B: 0.2 to 1.3 m/s^2 in 40 ms), and its start is the line's foot.
constexpr double kPitchStartWindowS = 0.04;
constexpr std::size_t kPitchStartSamples = 5;

double pitch_start_decel(const Run& r) {
  const std::size_t n = r.t_s.size();
  std::size_t m = 0;
  while (m < n && (m < kPitchStartSamples || r.t_s[m] - r.t_s[0] <= kPitchStartWindowS)) ++m;
  if (m < 2) return m ? r.ref_decel_mps2[0] : 0.0;
  std::vector<double> slopes;
  slopes.reserve(m * (m - 1) / 2);
  for (std::size_t i = 0; i < m; ++i)
    for (std::size_t j = i + 1; j < m; ++j)
      if (const double dt = r.t_s[j] - r.t_s[i]; dt > 0)
        slopes.push_back((r.ref_decel_mps2[j] - r.ref_decel_mps2[i]) / dt);
  const double slope = slopes.empty() ? 0.0 : upper_median(slopes);
  std::vector<double> feet(m);
  for (std::size_t i = 0; i < m; ++i) feet[i] = r.ref_decel_mps2[i] - slope * (r.t_s[i] - r.t_s[0]);
  return upper_median(feet);
}

}  // namespace

std::vector<double> pitch_lagged_decel(const Run& r, double lag_s, double mode_s2) {
  const std::size_t n = r.t_s.size();
  std::vector<double> out(n, 0.0);
  if (r.ref_decel_mps2.size() != n) return out;
  // Backward Euler on m x'' + lag x' + x = a (stable at any step; with m = 0 it is the implicit
  // first-order lag). The mode starts at rest on the deceleration the run starts at.
  double decel = n ? pitch_start_decel(r) : 0.0, rate = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    if (i > 0 && mode_s2 > 1e-9) {
      const double dt = r.t_s[i] - r.t_s[i - 1];
      rate =
          (mode_s2 * rate + dt * (r.ref_decel_mps2[i] - decel)) / (mode_s2 + dt * lag_s + dt * dt);
      decel += dt * rate;
    } else if (i > 0 && lag_s > 1e-6) {  // implicit Euler: no exp per sample
      const double dt = r.t_s[i] - r.t_s[i - 1];
      decel += (r.ref_decel_mps2[i] - decel) * dt / (lag_s + dt);
    } else if (i > 0 || (lag_s <= 1e-6 && mode_s2 <= 1e-9))  // no lag: the deceleration itself
      decel = r.ref_decel_mps2[i];
    out[i] = decel;
  }
  return out;
}

namespace {

/// A declared load transfer reads the fifth wheel's deceleration through a centred mean over
/// +-20 ms: the derivative of a quantised speed carries 0.1-0.2 m/s^2 of noise, which a load
/// law turns into force (on generator A's ground, 14 N at 3 kN), while the body's pitch (1-1.5
/// Hz) moves the load far slower than the mean's first zero (25 Hz).
constexpr double kDeclaredLoadHalfWindowS = 0.02;

/// The mean of y over the points within half_window_s of each point's time (zero phase).
std::vector<double> centred_mean(const std::vector<double>& t_s, const std::vector<double>& y,
                                 double half_window_s) {
  const std::size_t n = y.size();
  std::vector<double> out(n);
  std::size_t lo = 0, hi = 0;
  double sum = 0;
  for (std::size_t i = 0; i < n; ++i) {
    while (hi < n && t_s[hi] <= t_s[i] + half_window_s) sum += y[hi++];
    while (t_s[lo] < t_s[i] - half_window_s) sum -= y[lo++];
    out[i] = sum / static_cast<double>(hi - lo);
  }
  return out;
}

}  // namespace

/// sigma dk'/dx = k - k' along the rolled distance x, solved exactly for slip linear between
/// samples (the runs are decimated: an Euler step of 10-25 ms against a time constant sigma/V of
/// 40-300 ms would misplace the lag). y0: the transient slip at the first sample.
std::vector<double> relax_steps(const Run& r, double sigma_m) {
  const std::size_t n = r.t_s.size();
  std::vector<double> h(n, 0.0), decay(n, 0.0);
  for (std::size_t i = 1; i < n; ++i) {
    h[i] = (r.t_s[i] - r.t_s[i - 1]) * 0.5 * (r.v_ref_mps[i] + r.v_ref_mps[i - 1]) / sigma_m;
    decay[i] = -h[i];
  }
  exp_in_place(decay);
  for (std::size_t i = 1; i < n; ++i)
    if (h[i] < 1e-9) decay[i] = 1.0;              // the wheel stands: nothing rolls, nothing decays
  h.insert(h.end(), decay.begin(), decay.end());  // h, then exp(-h): one kept value
  return h;
}

std::vector<double> relax(const Run& r, const std::vector<double>& k, double sigma_m, double y0) {
  return relax(k, relax_steps(r, sigma_m), y0);
}

std::vector<double> relax(const std::vector<double>& k, const std::vector<double>& steps,
                          double y0) {
  const std::size_t n = k.size();
  const double* h = steps.data();
  const double* decay = steps.data() + n;
  std::vector<double> y(n);
  y[0] = std::clamp(y0, std::min(k[0], 0.0), std::max(k[0], 0.0));
  // y_i = c_i + a_i y_(i-1): the constants first (vectorised), then one multiply-add a step.
  std::vector<double> c(n, 0.0);
  for (std::size_t i = 1; i < n; ++i) {
    if (h[i] < 1e-9) continue;
    const double slope = (k[i] - k[i - 1]) / h[i];
    c[i] = k[i] - slope + (slope - k[i - 1]) * decay[i];
  }
  for (std::size_t i = 1; i < n; ++i) y[i] = c[i] + decay[i] * y[i - 1];
  return y;
}

std::vector<double> read_earlier(const std::vector<double>& t_s, const std::vector<double>& x,
                                 double dt_s) {
  const std::size_t n = x.size();
  if (n < 2 || std::all_of(x.begin(), x.end(), [&](double v) { return v == x.front(); })) return x;
  std::vector<double> out(n);
  std::size_t j = 1;  // the times read rise with i: walk to each one's interval
  for (std::size_t i = 0; i < n; ++i) {
    const double at = t_s[i] - dt_s;
    if (at <= t_s.front()) {
      out[i] = x.front();
    } else if (at >= t_s.back()) {
      out[i] = x.back();
    } else {
      while (t_s[j] <= at) ++j;
      const double w = (at - t_s[j - 1]) / (t_s[j] - t_s[j - 1]);
      out[i] = x[j - 1] + w * (x[j] - x[j - 1]);
    }
  }
  return out;
}

std::vector<double> filter_decays(const std::vector<double>& t_s, double tau_s) {
  std::vector<double> a(t_s.size(), 0.0);
  for (std::size_t i = 1; i < a.size(); ++i) a[i] = -std::max(t_s[i] - t_s[i - 1], 1e-9) / tau_s;
  exp_in_place(a);
  return a;
}

void filter_first_order(const std::vector<double>& t_s, std::vector<double>& f, double tau_s,
                        double y0) {
  filter_first_order(t_s, f, tau_s, y0, filter_decays(t_s, tau_s));
}

void filter_first_order(const std::vector<double>& t_s, std::vector<double>& f, double tau_s,
                        double y0, const std::vector<double>& a) {
  // Exact for an input linear between the points: y' = (u - y) / tau over a step dt with u
  // rising at k = (f1 - f0) / dt gives y1 = f1 - tau k + (y0 - f0 + tau k) exp(-dt / tau).
  if (f.empty()) return;
  // As y_i = c_i + a_i y_(i-1): the constants first (vectorised), then one multiply-add a step.
  const std::size_t n = f.size();
  std::vector<double> c(n, 0.0);
  for (std::size_t i = 1; i < n; ++i) {
    const double dt = std::max(t_s[i] - t_s[i - 1], 1e-9);
    const double tau_k = tau_s * (f[i] - f[i - 1]) / dt;
    c[i] = f[i] - tau_k + (tau_k - f[i - 1]) * a[i];
  }
  f[0] = y0;
  for (std::size_t i = 1; i < n; ++i) f[i] = c[i] + a[i] * f[i - 1];
}

namespace {

/// The values `make` computes for run r at (a, b): kept in the fit's cache where it has one,
/// else computed into `own`.
const std::vector<double>& kept(PredictCache* cache, const Run& r, PredictCache::Kind kind,
                                double a, double b, std::vector<double>& own,
                                const std::function<std::vector<double>()>& make) {
  if (cache) return cache->get(r, kind, a, b, make);
  own = make();
  return own;
}

}  // namespace

// GCC 12 at -O3 reports a bogus -Wfree-nonheap-object on the inlined vector destructors of this
// function (GCC bug 108088-like false positive; ASan finds nothing).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wfree-nonheap-object"
#endif
std::vector<double> predict(const Run& r, const std::vector<double>& p,
                            const std::vector<Effect>& effects) {
  return predict(r, p, effects, nullptr);
}

std::vector<double> predict(const Run& r, const std::vector<double>& p,
                            const std::vector<Effect>& effects, PredictCache* cache) {
  const std::size_t n = r.t_s.size();
  // d_scale scales D (the peak); b_scale scales B. Friction (speed friction, the other surface)
  // changes the peak but not the slip stiffness B C D (MF 6.1: lambda_mu enters D only), so B
  // takes the inverse scale; a load change scales both (Kx and D follow Fz).
  std::vector<double> d_scale(n, 1.0);
  std::vector<double> b_scale(n, 1.0);
  std::vector<double> add(n, 0.0);
  std::vector<double> e_add(n, 0.0);
  // The force-side effects first; the slip-side ones (relaxation, slip offset, time offset) are
  // then applied in that order whatever the order of `effects` (they commute but for the initial
  // state of the relaxation, which needs the force side), and speed friction at their slip.
  double sigma_m = 0, slip_offset = 0, dt_s = 0, threshold_n = 0, cap_n = INFINITY, lambda_mu_v = 0;
  double fade_per_kj = 0;
  bool relaxation = false, threshold = false;
  // A load following the deceleration a: D by 1 + q a, B C D by (1 + q a)^ratio, E by e q a.
  auto follow_load = [&](const std::vector<double>& decel, double q, double ratio, double e_slope) {
    std::vector<double> power(n);  // load^(ratio - 1) as exp((ratio - 1) log load), as vectors
    for (std::size_t i = 0; i < n; ++i) {
      const double load = std::max(0.05, 1.0 + q * decel[i]);
      d_scale[i] *= load;
      e_add[i] += e_slope * (load - 1.0);
      power[i] = load;
    }
    if (ratio == 1.0) return;
    log_in_place(power);
    for (double& x : power) x *= ratio - 1.0;
    exp_in_place(power);
    for (std::size_t i = 0; i < n; ++i) b_scale[i] *= power[i];
  };
  // A declared load is read through the tyre's load laws as a measured one is: E too changes
  // with the load, at the tyre's file's slope or the published tyres' 0.25.
  if (const double q = r.declared_load_per_decel_s2_per_m; q != 0 && r.ref_decel_mps2.size() == n)
    follow_load(centred_mean(r.t_s, r.ref_decel_mps2, kDeclaredLoadHalfWindowS), q,
                r.declared_kx_load_ratio, r.load_laws.e_per_peak_scale);
  std::size_t next = 4;  // index of the current effect's first parameter in p
  for (const Effect effect : effects) {
    const double q = p[next];
    const std::size_t first = next;
    next += effect_params(effect).size();
    switch (effect) {
      case Effect::TimeOffset:  // the force channel is late by dt: it shows the tyre at t - dt
        dt_s = q;
        break;
      case Effect::SlipOffset:
      case Effect::ReferenceBias:
      case Effect::TyreShift:
        slip_offset += q;
        break;
      case Effect::RelaxationLength:
        relaxation = true;
        sigma_m = std::max(q, 1e-6);
        break;
      case Effect::BrakeThreshold:  // gain p = Tb/R + gain p0 (below p0: no torque, see below)
        threshold = true;
        threshold_n = r.brake_gain_n_per_bar * q;
        break;
      case Effect::WheelInertia:  // I w' = F R - Tb  =>  Tb/R = F - I a_wheel / R^2
        for (std::size_t i = 0; i < n; ++i)
          add[i] -= q * r.wheel_accel_mps2[i] / (r.wheel_radius_m * r.wheel_radius_m);
        break;
      case Effect::LoadTransfer:
      case Effect::LoadTransferShape:
      case Effect::LoadTransferMeasured:  // Fz grows with the measured deceleration
      {
        const double lag_s = p[first + effect_params(effect).size() - 2];
        const double mode_s2 = p[first + effect_params(effect).size() - 1];
        std::vector<double> own;
        follow_load(
            kept(cache, r, PredictCache::Kind::Pitch, lag_s, mode_s2, own,
                 [&] { return pitch_lagged_decel(r, lag_s, mode_s2); }),
            q, effect == Effect::LoadTransferMeasured ? r.load_laws.kx_over_peak : p[first + 1],
            effect == Effect::LoadTransferShape      ? p[first + 2]
            : effect == Effect::LoadTransferMeasured ? r.load_laws.e_per_peak_scale
                                                     : 0.0);
        break;
      }
      case Effect::SpeedFriction:  // applied below, at the slip the curve is read at
        lambda_mu_v = q;
        break;
      case Effect::FrictionFade:  // a named effect's rival (fade_rival.cpp), applied below
        fade_per_kj = q;
        break;
      case Effect::CradleCap:  // the cradle caps the tyre's force (before the wheel's terms)
        cap_n = q;
        break;
      case Effect::RollerFriction:  // the other surface's friction: D scales, B C D does not
        for (std::size_t i = 0; i < n; ++i) {
          d_scale[i] *= q;
          b_scale[i] /= q;
        }
        break;
    }
  }
  std::vector<double> slip = r.slip;
  // A lag (a time offset, a relaxation) levels the runs' reference biases at itself, not at
  // none (level_reference_biases): the run's bias moves by level_shift.
  double level_shift = 0;
  const double relaxed_change = relaxation ? relaxation_level_change(r, sigma_m) : 0.0;
  if (r.ref_bias_bound > 0 && ((r.ref_bias_per_lag != 0 && dt_s != 0) || relaxed_change != 0)) {
    level_shift = r.ref_bias_removed -
                  std::clamp(r.ref_bias_wanted + r.ref_bias_per_lag * dt_s + relaxed_change,
                             -r.ref_bias_bound, r.ref_bias_bound);
    for (double& s : slip) s += level_shift;
  }
  if (relaxation) {
    // Initial transient slip: the one whose force (linear region) is the measured initial force.
    const double stiffness_n = p[0] * p[1] * p[2] * d_scale[0] * b_scale[0];
    const double k0 =
        stiffness_n > 0 ? (r.initial_force_n - add[0] - std::min(threshold_n, r.initial_force_n)) /
                                  stiffness_n +
                              slip_offset + level_shift
                        : slip.front();
    std::vector<double> own;
    slip = relax(slip,
                 kept(cache, r, PredictCache::Kind::Relax, sigma_m, 0.0, own,
                      [&] { return relax_steps(r, sigma_m); }),
                 k0);
  }
  if (slip_offset != 0)
    for (double& s : slip) s -= slip_offset;
  if (dt_s != 0) {
    const double s0 = slip.front(), t0 = r.t_s.front();
    slip = read_earlier(r.t_s, slip, dt_s);
    for (std::size_t i = 0; i < n && r.t_s[i] - dt_s < t0; ++i)  // before the run: the ramp
      slip[i] =
          std::max(s0 + r.initial_slip_rate_per_s * (r.t_s[i] - dt_s - t0), std::min(s0, 0.0));
    // The channel is late as a whole: the wheel's inertial force in it shows dt late too. (A
    // load's timing is its own law's, the body's pitch lag, which would trade with dt here.)
    add = read_earlier(r.t_s, add, dt_s);
  }
  // Speed friction, lambda_mu* = 1 / (1 + LMUV Vs / V0): the friction falls with the contact's
  // sliding speed, Vs = slip x V at the slip the curve is read at (a relaxing tyre's transient
  // slip, less an offset the encoder added; a late channel's at its own moment), not the
  // encoders' slip, which leads a relaxing contact's by sigma / V: read on it the friction falls
  // too early.
  if (lambda_mu_v != 0) {
    std::vector<double> earlier;  // the speed a late channel shows (predict runs per iteration)
    if (dt_s != 0) earlier = read_earlier(r.t_s, r.v_ref_mps, dt_s);
    const std::vector<double>& v_mps = dt_s != 0 ? earlier : r.v_ref_mps;
    for (std::size_t i = 0; i < n; ++i) {
      const double mu = 1.0 / (1.0 + lambda_mu_v * std::abs(slip[i]) * v_mps[i] / kLongVl);
      d_scale[i] *= mu;
      b_scale[i] /= mu;
    }
  }
  // A friction fading with the energy slid so far, mu / (1 + k E): E from the run's own force
  // channel, slip and speed (the tyre's heat is what it slid, whatever the law of its curve).
  if (fade_per_kj != 0) {
    const std::vector<double> e_kj = slid_energy_kj(r);
    for (std::size_t i = 0; i < n; ++i) d_scale[i] /= 1.0 + fade_per_kj * e_kj[i];
  }
  // The Magic Formula, F = D sin(C atan(phi)), phi = u - E (u - atan u), u = B x, a stage at a
  // time over the run so that the arctangents and the sine run as vectors (core/vecmath.hpp).
  std::vector<double> u(n), atan_u(n), f(n);
  for (std::size_t i = 0; i < n; ++i) u[i] = atan_u[i] = p[0] * b_scale[i] * slip[i];
  atan_in_place(atan_u);
  for (std::size_t i = 0; i < n; ++i) {
    const double e = std::min(p[3] + e_add[i], 1.0);
    f[i] = u[i] - e * (u[i] - atan_u[i]);
  }
  atan_in_place(f);
  for (std::size_t i = 0; i < n; ++i) f[i] *= p[1];
  sin_in_place(f);
  for (std::size_t i = 0; i < n; ++i) {
    f[i] = std::min(p[2] * d_scale[i] * f[i], cap_n) + add[i];
    // Brake threshold: gain p = Tb/R + gain p0 while the brake bites; below p0 the pads give no
    // torque and the measured pressure can be anything up to p0: gain min(p, p0) is added.
    // Behind a declared filter the pads bite when the line's pressure passes p0, not the
    // channel's: the line's is the channel's plus tau times its rate.
    if (threshold)
      f[i] += std::min(threshold_n, r.force_n[i] + r.pressure_filter_s * r.brake_gain_n_per_bar *
                                                       std::max(r.pressure_rate_bar_per_s[i], 0.0));
  }
  // The filter's state at the run's first point is what the channel showed there (a run can
  // start on the ramp, less than tau after it began: neither at rest nor settled on it).
  if (const double tau_s = r.pressure_filter_s; tau_s > 0) {
    std::vector<double> own;
    filter_first_order(r.t_s, f, tau_s, r.force_n.front(),
                       kept(cache, r, PredictCache::Kind::FilterDecay, tau_s, 0.0, own,
                            [&] { return filter_decays(r.t_s, tau_s); }));
  }
  return f;
}

#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

}  // namespace brakefit::gap
