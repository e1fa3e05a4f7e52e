#include "core/gap/gap.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <numeric>
#include <span>

#include "core/curve.hpp"
#include "core/fit/lm.hpp"

namespace brakefit::gap {

// Gates (see calibrated_options): max(0.10, 1.5 x the largest null gain) and max(10, 1.5 x the
// largest null BIC drop) over 30 null sets per condition (bench/gap_referee --calibrate 30).
// Null maxima measured 2026-11-21: roller gain 0.005, dBIC -2.4; ground 0.013, -10.1; roller vs
// road 0.146, -305.8 (the roller fit carried to the road leaves a small bias every transfer
// candidate nibbles at).
constexpr double kRollerGateGain = 0.10, kRollerBicMargin = 10.0;
constexpr double kGroundGateGain = 0.10, kGroundBicMargin = 16.0;
constexpr double kTransferGateGain = 0.22, kTransferBicMargin = 460.0;

const char* to_string(Effect e) {
  switch (e) {
    case Effect::RelaxationLength:
      return "relaxation_length";
    case Effect::TimeOffset:
      return "time_offset";
    case Effect::WheelInertia:
      return "wheel_inertia";
    case Effect::BrakeThreshold:
      return "brake_threshold";
    case Effect::SlipOffset:
      return "slip_offset";
    case Effect::LoadTransfer:
    case Effect::LoadTransferShape:
      return "load_transfer";
    case Effect::SpeedFriction:
      return "speed_friction";
    case Effect::RollerFriction:
      return "roller_friction";
    case Effect::CradleCap:
      return "cradle_cap";
  }
  return "?";
}

const char* to_string(Condition c) {
  switch (c) {
    case Condition::Roller:
      return "roller";
    case Condition::Ground:
      return "ground";
    case Condition::RollerToRoad:
      return "roller_vs_road";
  }
  return "?";
}

Options calibrated_options(Condition c, Options base) {
  // Seeds of the null sets 1 000 000+, disjoint from the referee's.
  switch (c) {
    case Condition::Roller:
      base.gate_gain = kRollerGateGain;
      base.bic_margin = kRollerBicMargin;
      break;
    case Condition::Ground:
      base.gate_gain = kGroundGateGain;
      base.bic_margin = kGroundBicMargin;
      break;
    case Condition::RollerToRoad:
      base.gate_gain = kTransferGateGain;
      base.bic_margin = kTransferBicMargin;
      break;
  }
  return base;
}

std::span<const EffectParam> effect_params(Effect e) {
  // q scales the peak D by 1 + q x deceleration; the slip stiffness B C D scales by
  // (1 + q x deceleration)^r: a tyre's stiffness and peak grow differently with load (MF 6.1:
  // PKX1-3 vs PDX1-2; r 1.3 for the simulated TNO 205/60R15), and one ratio for both misread q by
  // 40 %. Against a held curve E moves with the load as well (PEX2: E += e x relative load).
  // Built once: predict() asks for every evaluation of the fits.
  constexpr auto kEffects = static_cast<std::size_t>(Effect::CradleCap) + 1;
  static const std::array<std::vector<EffectParam>, kEffects> table = [] {
    std::array<std::vector<EffectParam>, kEffects> t;
    for (std::size_t i = 0; i < kEffects; ++i) t[i] = {effect_param(static_cast<Effect>(i))};
    t[static_cast<std::size_t>(Effect::LoadTransfer)].push_back({"kx_load_ratio", 0.0, 3.0, 1.0});
    auto& shape = t[static_cast<std::size_t>(Effect::LoadTransferShape)];
    shape.push_back({"kx_load_ratio", 0.0, 3.0, 1.0});
    shape.push_back({"e_per_load", -2.0, 2.0, 0.0});
    return t;
  }();
  return table[static_cast<std::size_t>(e)];
}

std::size_t param_count(const std::vector<Effect>& effects) {
  std::size_t n = 4;
  for (Effect e : effects) n += effect_params(e).size();
  return n;
}

std::vector<std::string> param_names(const std::vector<Effect>& effects) {
  std::vector<std::string> names{"B", "C", "D", "E"};
  for (Effect e : effects)
    for (const auto& p : effect_params(e)) names.emplace_back(p.name);
  return names;
}

EffectParam effect_param(Effect e) {
  switch (e) {
    case Effect::RelaxationLength:
      return {"sigma_m", 1e-4, 2.0, 0.05};
    case Effect::TimeOffset:
      return {"dt_s", -0.3, 0.3, 0.0};
    case Effect::WheelInertia:
      return {"inertia_kgm2", 0.0, 20.0, 0.5};
    case Effect::BrakeThreshold:
      return {"p0_bar", -10.0, 30.0, 0.0};
    case Effect::SlipOffset:
      return {"slip_offset_ratio", -0.05, 0.05, 0.0};
    case Effect::LoadTransfer:
    case Effect::LoadTransferShape:
      return {"dfz_per_decel_s2_per_m", -0.2, 0.2, 0.0};
    case Effect::SpeedFriction:
      return {"lambda_mu_v", 0.0, 20.0, 0.1};
    case Effect::RollerFriction:
      return {"mu_ratio", 0.3, 2.0, 1.0};
    case Effect::CradleCap:
      return {"cap_n", 100.0, 1e5, 0.0};  // start and fit range: from the runs' peak force
  }
  return {"?", 0, 0, 0};
}

namespace {

constexpr double kLongVl = 16.7;  // MF 6.1 reference speed V0, m/s

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

}  // namespace

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

namespace {

/// sigma dk'/dx = k - k' along the rolled distance x, solved exactly for slip linear between
/// samples (the runs are decimated: an Euler step of 10-25 ms against a time constant sigma/V of
/// 40-300 ms would misplace the lag). y0: the transient slip at the first sample.
std::vector<double> relax(const Run& r, const std::vector<double>& k, double sigma_m, double y0) {
  const std::size_t n = k.size();
  std::vector<double> y(n);
  y[0] = std::clamp(y0, std::min(k[0], 0.0), std::max(k[0], 0.0));
  for (std::size_t i = 1; i < n; ++i) {
    const double h =
        (r.t_s[i] - r.t_s[i - 1]) * 0.5 * (r.v_ref_mps[i] + r.v_ref_mps[i - 1]) / sigma_m;
    if (h < 1e-9) {
      y[i] = y[i - 1];
      continue;
    }
    const double slope = (k[i] - k[i - 1]) / h;
    y[i] = k[i] - slope + (y[i - 1] - k[i - 1] + slope) * std::exp(-h);
  }
  return y;
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
  // state of the relaxation, which needs the force side).
  double sigma_m = 0, slip_offset = 0, dt_s = 0, threshold_n = 0, cap_n = INFINITY;
  bool relaxation = false, threshold = false;
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
        slip_offset = q;
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
      case Effect::LoadTransferShape: {  // Fz grows with the measured deceleration: D by 1 + q a,
                                         // B C D by (1 + q a)^r, E by e q a
        const double ratio = p[first + 1];
        const double e_slope = effect == Effect::LoadTransferShape ? p[first + 2] : 0.0;
        for (std::size_t i = 0; i < n; ++i) {
          const double load = std::max(0.05, 1.0 + q * r.ref_decel_mps2[i]);
          d_scale[i] *= load;
          b_scale[i] *= std::pow(load, ratio - 1.0);
          e_add[i] += e_slope * (load - 1.0);
        }
        break;
      }
      case Effect::SpeedFriction:  // lambda_mu* = 1 / (1 + LMUV Vs / V0), Vs = slip * V
        for (std::size_t i = 0; i < n; ++i) {
          const double mu = 1.0 / (1.0 + q * std::abs(r.slip[i]) * r.v_ref_mps[i] / kLongVl);
          d_scale[i] *= mu;
          b_scale[i] /= mu;
        }
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
  if (relaxation) {
    // Initial transient slip: the one whose force (linear region) is the measured initial force.
    const double stiffness_n = p[0] * p[1] * p[2] * d_scale[0] * b_scale[0];
    const double k0 =
        stiffness_n > 0 ? (r.initial_force_n - add[0] - std::min(threshold_n, r.initial_force_n)) /
                                  stiffness_n +
                              slip_offset
                        : slip.front();
    slip = relax(r, slip, sigma_m, k0);
  }
  if (slip_offset != 0)
    for (double& s : slip) s -= slip_offset;
  if (dt_s != 0) {
    std::vector<double> shifted(n);
    const double s0 = slip.front(), t0 = r.t_s.front();
    for (std::size_t i = 0; i < n; ++i) {
      const double at = r.t_s[i] - dt_s;
      // Before the run: the ramp from zero slip that led into it.
      shifted[i] = at >= t0
                       ? interp(r.t_s, slip, at)
                       : std::max(s0 + r.initial_slip_rate_per_s * (at - t0), std::min(s0, 0.0));
    }
    slip = std::move(shifted);
  }
  std::vector<double> f(n);
  const MfParams base{p[0], p[1], p[2], p[3], 0, 0};
  for (std::size_t i = 0; i < n; ++i) {
    MfParams m = base;
    m.D *= d_scale[i];
    m.B *= b_scale[i];
    m.E = std::min(m.E + e_add[i], 1.0);
    f[i] = std::min(mf_force_n(m, slip[i]), cap_n) + add[i];
    // Brake threshold: gain p = Tb/R + gain p0 while the brake bites; below p0 the pads give no
    // torque and the measured pressure can be anything up to p0: gain min(p, p0) is added.
    if (threshold) f[i] += std::min(threshold_n, r.force_n[i]);
  }
  return f;
}

#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic pop
#endif

double Fit::bic() const {
  const double n = static_cast<double>(points);
  return n * std::log(std::max(ssr, 1e-300) / n) + static_cast<double>(params.size()) * std::log(n);
}

namespace {

class GapProblem final : public fit::LeastSquaresProblem {
 public:
  GapProblem(const std::vector<const Run*>& runs, const std::vector<Effect>& effects,
             std::vector<double> fixed_base = {})
      : runs_(runs), effects_(effects), base_(std::move(fixed_base)) {
    for (const Run* r : runs_) n_ += static_cast<Eigen::Index>(r->t_s.size());
  }
  Eigen::Index residual_count() const override { return n_; }
  void evaluate(const Eigen::VectorXd& x, Eigen::VectorXd& res, Eigen::MatrixXd* j) const override {
    residuals(x, res);
    if (!j) return;
    Eigen::VectorXd rp(n_), rm(n_);
    for (Eigen::Index k = 0; k < x.size(); ++k) {
      const double h = 1e-6 * std::max(1.0, std::abs(x(k)));
      Eigen::VectorXd xp = x, xm = x;
      xp(k) += h;
      xm(k) -= h;
      residuals(xp, rp);
      residuals(xm, rm);
      j->col(k) = (rp - rm) / (2 * h);
    }
  }

 private:
  void residuals(const Eigen::VectorXd& x, Eigen::VectorXd& res) const {
    std::vector<double> p = base_;  // empty unless B, C, D, E are held
    p.insert(p.end(), x.data(), x.data() + x.size());
    Eigen::Index o = 0;
    for (const Run* r : runs_) {
      const auto f = predict(*r, p, effects_);
      for (std::size_t i = 0; i < f.size(); ++i) res(o++) = f[i] - r->force_n[i];
    }
  }
  const std::vector<const Run*>& runs_;
  const std::vector<Effect>& effects_;
  std::vector<double> base_;
  Eigen::Index n_ = 0;
};

}  // namespace

Fit fit_runs(const std::vector<const Run*>& runs, const std::vector<Effect>& effects,
             const MfParams& start) {
  const auto np = static_cast<Eigen::Index>(param_count(effects));
  double peak = 0;
  for (const Run* r : runs)
    for (double f : r->force_n) peak = std::max(peak, std::abs(f));
  Eigen::VectorXd lo(np), hi(np), x0(np);
  lo.head(4) << 0.1, 0.3, 0.0, -20.0;
  hi.head(4) << 200.0, 3.0, 5.0 * peak, 1.0;
  x0.head(4) << start.B, start.C, start.D, start.E;
  Eigen::Index i = 4;
  for (Effect e : effects)
    for (const EffectParam& ep : effect_params(e)) {
      const bool cap = e == Effect::CradleCap;  // starts at the largest force measured
      lo(i) = cap ? 0.3 * peak : ep.lo;
      hi(i) = cap ? 2.0 * peak : ep.hi;
      x0(i++) = cap ? peak : ep.start;
    }
  GapProblem problem(runs, effects);
  fit::LmOptions lm;
  lm.max_iterations = 100;
  const fit::LmResult r = fit::minimize(problem, x0, lo, hi, lm);
  Fit out;
  out.params.assign(r.x.data(), r.x.data() + r.x.size());
  out.stderr_.assign(r.standard_errors.data(), r.standard_errors.data() + r.standard_errors.size());
  out.ssr = r.ssr;
  out.points = static_cast<std::size_t>(problem.residual_count());
  return out;
}

Fit fit_effects(const std::vector<const Run*>& runs, const std::vector<Effect>& effects,
                const MfParams& base) {
  const std::vector<double> b{base.B, base.C, base.D, base.E};
  Fit out;
  out.params = b;
  out.stderr_.assign(4, NAN);
  std::size_t n = 0;
  for (const Run* r : runs) n += r->t_s.size();
  out.points = n;
  if (effects.empty()) {
    for (const Run* r : runs) {
      const auto f = predict(*r, b, {});
      for (std::size_t i = 0; i < f.size(); ++i)
        out.ssr += (f[i] - r->force_n[i]) * (f[i] - r->force_n[i]);
    }
    return out;
  }
  const auto np = static_cast<Eigen::Index>(param_count(effects) - 4);
  Eigen::VectorXd lo(np), hi(np), x0(np);
  Eigen::Index i = 0;
  for (Effect e : effects)
    for (const EffectParam& ep : effect_params(e)) {
      lo(i) = ep.lo;
      hi(i) = ep.hi;
      x0(i++) = ep.start;
    }
  GapProblem problem(runs, effects, b);
  fit::LmOptions lm;
  lm.max_iterations = 100;
  const fit::LmResult r = fit::minimize(problem, x0, lo, hi, lm);
  out.params.insert(out.params.end(), r.x.data(), r.x.data() + r.x.size());
  out.stderr_.insert(out.stderr_.end(), r.standard_errors.data(),
                     r.standard_errors.data() + r.standard_errors.size());
  out.ssr = r.ssr;
  return out;
}

double rmse(const Run& r, const std::vector<double>& params, const std::vector<Effect>& effects) {
  const auto f = predict(r, params, effects);
  double s = 0;
  for (std::size_t i = 0; i < f.size(); ++i) s += (f[i] - r.force_n[i]) * (f[i] - r.force_n[i]);
  return std::sqrt(s / static_cast<double>(f.size()));
}

namespace {

bool at_bound(double v, double lo, double hi) {
  const double tol = 0.005 * (hi - lo);
  return v <= lo + tol || v >= hi - tol;
}

/// Fits B, C, D, E and the effects to some runs (jointly, or with B, C, D, E held).
using Fitter = std::function<Fit(const std::vector<const Run*>&, const std::vector<Effect>&)>;

/// Leave-one-run-out: RMS over runs of the held-out RMSE with parameters fitted on the others.
double heldout(const std::vector<Run>& runs, const std::vector<Effect>& effects,
               const Fitter& fit) {
  double sq = 0;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    std::vector<const Run*> train;
    for (std::size_t i = 0; i < runs.size(); ++i)
      if (i != k) train.push_back(&runs[i]);
    const double e = rmse(runs[k], fit(train, effects).params, effects);
    sq += e * e;
  }
  return std::sqrt(sq / static_cast<double>(runs.size()));
}

double noise_of(const std::vector<Run>& runs) {
  double sq = 0;
  for (const Run& r : runs) sq += r.noise_n * r.noise_n;
  return std::sqrt(sq / static_cast<double>(runs.size()));
}

std::vector<const Run*> pointers(const std::vector<Run>& runs) {
  std::vector<const Run*> out;
  out.reserve(runs.size());
  for (const Run& r : runs) out.push_back(&r);
  return out;
}

/// Where: residual of the 4-parameter model by slip region, by phase, by run.
std::vector<WhereRow> where_rows(const std::vector<Run>& runs, const std::vector<double>& params) {
  const MfParams base{params[0], params[1], params[2], params[3], 0, 0};
  std::vector<WhereRow> out;
  const double peak_slip = mf_peak(base, 1.0).slip_ratio;
  std::vector<std::pair<std::string, double>> acc;
  auto add = [&](const std::string& region, double r2) {
    for (auto& [name, v] : acc)
      if (name == region) return void(v += r2);
    acc.emplace_back(region, r2);
  };
  std::vector<std::pair<std::string, std::size_t>> counts;
  auto count = [&](const std::string& region) {
    for (auto& [name, v] : counts)
      if (name == region) return void(++v);
    counts.emplace_back(region, 1);
  };
  double total = 0;
  for (const Run& r : runs) {
    const auto f = predict(r, params, {});
    for (std::size_t i = 0; i < f.size(); ++i) {
      const double r2 = (r.force_n[i] - f[i]) * (r.force_n[i] - f[i]);
      total += r2;
      const std::string slip_region = r.slip[i] < 0.5 * peak_slip   ? "linear"
                                      : r.slip[i] < 1.5 * peak_slip ? "near_peak"
                                                                    : "after_peak";
      const std::string phase = r.pressure_rate_bar_per_s[i] >= 0 ? "apply" : "release";
      for (const std::string& reg : {slip_region, "phase:" + phase, "run:" + r.name}) {
        add(reg, r2);
        count(reg);
      }
    }
  }
  for (std::size_t k = 0; k < acc.size(); ++k)
    out.push_back({acc[k].first, std::sqrt(acc[k].second / static_cast<double>(counts[k].second)),
                   total > 0 ? acc[k].second / total : 0.0});

  return out;
}

/// A neutral Magic Formula for the runs: D their peak force, C 1.65, E 0, B from the slope of the
/// force over slip below 30 % of the peak (B C D = the slip stiffness).
MfParams neutral_start(const std::vector<Run>& runs) {
  double peak = 0;
  for (const Run& r : runs)
    for (double f : r.force_n) peak = std::max(peak, f);
  double sxy = 0, sxx = 0;  // slope through the origin
  for (const Run& r : runs)
    for (std::size_t i = 0; i < r.slip.size(); ++i)
      if (r.force_n[i] < 0.3 * peak && r.slip[i] > 0) {
        sxy += r.slip[i] * r.force_n[i];
        sxx += r.slip[i] * r.slip[i];
      }
  MfParams m{10.0, 1.65, std::max(peak, 1.0), 0.0, 0, 0};
  if (sxx > 0 && sxy > 0) m.B = std::clamp(sxy / sxx / (m.C * m.D), 1.0, 100.0);
  return m;
}

/// Forward selection on held-out error, shared by both modes: rep holds the baseline (before,
/// gap_before_rmse_n, noise_n); fills effects, accepted, after, gap_after_rmse_n, verdict, notes.
void select_effects(Report& rep, const std::vector<Run>& runs,
                    const std::vector<Effect>& candidates, const Fitter& fit, const Options& o,
                    const char* separability_note) {
  const std::vector<const Run*> all = pointers(runs);
  std::vector<Effect> chosen;
  double current_heldout = rep.gap_before_rmse_n;
  Fit current_fit = rep.before;
  for (std::size_t round = 0; round < o.max_effects; ++round) {
    std::vector<EffectScore> scores;
    std::vector<Fit> fits;
    for (Effect e : candidates) {
      if (std::find(chosen.begin(), chosen.end(), e) != chosen.end()) continue;
      std::vector<Effect> model = chosen;
      model.push_back(e);
      EffectScore s;
      s.effect = e;
      s.heldout_rmse_before_n = current_heldout;
      s.heldout_rmse_after_n = heldout(runs, model, fit);
      s.gain = 1.0 - s.heldout_rmse_after_n / std::max(current_heldout, 1e-12);
      Fit f = fit(all, model);
      s.delta_bic = f.bic() - current_fit.bic();
      const auto eps = effect_params(e);
      for (std::size_t j = 0; j < eps.size(); ++j)
        s.params.emplace_back(eps[j].name, f.params[f.params.size() - eps.size() + j]);
      scores.push_back(s);
      fits.push_back(std::move(f));
    }
    if (scores.empty()) break;
    std::vector<std::size_t> order(scores.size());
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(),
              [&](std::size_t a, std::size_t b) { return scores[a].gain > scores[b].gain; });
    auto passes = [&](const EffectScore& e) {
      return e.gain >= o.gate_gain && e.delta_bic <= -o.bic_margin;
    };
    // The best candidate past the gates whose parameters all lie inside their physical ranges (a
    // misspecified curve on the ground was taken for load transfer with the stiffness ratio at
    // its end, 3); one at the end of a range is noted and the next one is considered.
    std::size_t pick = order.size();
    for (std::size_t k = 0; k < order.size() && pick == order.size(); ++k) {
      EffectScore& e = scores[order[k]];
      if (!passes(e)) break;  // sorted by gain: the rest do not pass the gain gate either
      const auto eps = effect_params(e.effect);
      bool inside = true;
      for (std::size_t j = 0; j < eps.size() && inside; ++j) {
        const double v = e.params[j].second;
        if (!at_bound(v, eps[j].lo, eps[j].hi)) continue;
        inside = false;
        rep.notes.push_back(
            fmt::format("{} would explain part of the residual only with {} at the "
                        "end of its physical range ({:.4g}): not accepted",
                        to_string(e.effect), eps[j].name, v));
      }
      if (inside) pick = k;
    }
    if (pick < order.size()) {
      EffectScore& best = scores[order[pick]];
      best.accepted = true;
      for (std::size_t k = pick + 1; k < order.size(); ++k) {
        const EffectScore& next = scores[order[k]];
        if (passes(next) && best.gain - next.gain < o.separability * best.gain)
          rep.notes.push_back(fmt::format(fmt::runtime(separability_note), to_string(best.effect),
                                          to_string(next.effect), best.gain, next.gain));
        break;
      }
    }
    if (round == 0) rep.effects = scores;
    if (pick == order.size()) break;
    const EffectScore& best = scores[order[pick]];
    if (round > 0) rep.effects.push_back(best);
    chosen.push_back(best.effect);
    current_heldout = best.heldout_rmse_after_n;
    current_fit = fits[order[pick]];
  }
  // Fit quality: effects that leave most of a structured gap in place are not its cause (a curve
  // that is not a Magic Formula makes every candidate nibble at it): nothing is named then.
  double first = 0.0;
  for (const auto& e : rep.effects)
    if (!chosen.empty() && e.effect == chosen.front()) first = e.gain;
  if (!chosen.empty() && current_heldout > o.noise_factor * rep.noise_n &&
      first < o.min_first_gain) {
    rep.notes.push_back(fmt::format(
        "the best candidate ({}) explains only {:.0f} % of the held-out gap and {:.1f} N are left "
        "against {:.1f} N of noise: the residual has a structure no candidate explains (is the "
        "curve a Magic Formula?), so no effect is named",
        to_string(chosen.front()), 100 * first, current_heldout, rep.noise_n));
    for (auto& e : rep.effects) e.accepted = false;
    chosen.clear();
    current_fit = rep.before;
    current_heldout = rep.gap_before_rmse_n;
  }
  rep.accepted = chosen;
  rep.after = current_fit;
  rep.gap_after_rmse_n = current_heldout;
  for (Effect e : chosen) rep.verdict.push_back(to_string(e));
  const bool gap_left = rep.gap_after_rmse_n > o.noise_factor * rep.noise_n;
  if (chosen.empty()) {
    rep.verdict.push_back(gap_left ? "unexplained" : "none");
  } else if (gap_left) {
    rep.verdict.push_back("unexplained");
  }
}

}  // namespace

namespace {

/// The run up to its first sample whose slip (or force) is above the limit.
Run up_to(const Run& r, const std::vector<double>& x, double limit) {
  std::size_t n = 0;
  while (n < x.size() && x[n] <= limit) ++n;
  Run out = r;
  for (auto* v : {&out.t_s, &out.slip, &out.v_ref_mps, &out.force_n, &out.wheel_accel_mps2,
                  &out.ref_decel_mps2, &out.pressure_rate_bar_per_s})
    v->resize(n);
  return out;
}

/// Least-squares slope of force over slip for the samples with force in [lo, hi].
double force_slope(const Run& r, double lo_n, double hi_n) {
  double sk = 0, sf = 0, skk = 0, skf = 0, m = 0;
  for (std::size_t i = 0; i < r.slip.size(); ++i) {
    if (r.force_n[i] < lo_n || r.force_n[i] > hi_n) continue;
    sk += r.slip[i];
    sf += r.force_n[i];
    skk += r.slip[i] * r.slip[i];
    skf += r.slip[i] * r.force_n[i];
    ++m;
  }
  const double den = m * skk - sk * sk;
  return m >= 5 && den > 0 ? (m * skf - sk * sf) / den : NAN;
}

}  // namespace

std::optional<CapEvidence> cradle_cap_evidence(const std::vector<Run>& runs) {
  if (runs.size() < 2) return std::nullopt;
  for (const Run& r : runs)
    if (r.bench != can::BenchKind::Roller) return std::nullopt;  // a cradle is a roller's
  double lo = INFINITY, hi = 0, sum = 0, ratio = INFINITY;
  for (const Run& r : runs) {
    if (!r.runaway) return std::nullopt;
    const double f = r.runaway_force_n;
    lo = std::min(lo, f);
    hi = std::max(hi, f);
    sum += f;
    const double initial = force_slope(r, 0.05 * f, 0.3 * f);
    const double end = force_slope(r, 0.85 * f, 1.0 * f);
    if (!(initial > 0) || !std::isfinite(end)) return std::nullopt;
    ratio = std::min(ratio, end / initial);
  }
  CapEvidence e;
  e.cap_n = sum / static_cast<double>(runs.size());
  e.spread = (hi - lo) / e.cap_n;
  e.end_slope_ratio = ratio;
  if (e.spread > 0.03 || e.end_slope_ratio < 0.3) return std::nullopt;
  return e;
}

namespace {

/// A cradle cap found on the runs (not fitted) goes first: its held-out gap before is the whole
/// runs' (gap_whole_n), after the gap below the cap (rep's baseline gap so far).
void put_cap_first(Report& rep, double cap_n, double gap_whole_n) {
  rep.cap_n = cap_n;
  EffectScore c;
  c.effect = Effect::CradleCap;
  c.params = {{"cap_n", cap_n}};
  c.heldout_rmse_before_n = gap_whole_n;
  c.heldout_rmse_after_n = rep.gap_before_rmse_n;
  c.gain = 1.0 - c.heldout_rmse_after_n / std::max(c.heldout_rmse_before_n, 1e-12);
  c.delta_bic = NAN;  // not a fitted model
  c.accepted = true;
  rep.effects.insert(rep.effects.begin(), c);
  if (rep.verdict == std::vector<std::string>{"none"}) rep.verdict.clear();
  rep.verdict.insert(rep.verdict.begin(), to_string(Effect::CradleCap));
  rep.gap_before_rmse_n = gap_whole_n;
}

}  // namespace

Report diagnose(const std::vector<Run>& runs_in, const MfParams& start, const Options& o) {
  if (runs_in.size() < 2)
    throw InputError(
        "gap diagnosis needs at least two runs (it checks every effect on a run it was not fitted "
        "to)");
  // A force cap (a two-roller cradle): the runs end in a runaway at the cap; the samples from 98 %
  // of the cap on are that runaway, not the tyre, and are left out.
  const auto cap = cradle_cap_evidence(runs_in);
  std::vector<Run> runs;
  for (const Run& r : runs_in) {
    Run cut = cap ? up_to(r, r.force_n, 0.98 * cap->cap_n) : r;
    if (cut.t_s.size() >= 20) runs.push_back(std::move(cut));
  }
  if (runs.size() < 2)
    throw InputError("gap diagnosis: fewer than two runs with 20 samples below the force cap");
  Report rep;
  rep.noise_n = noise_of(runs);
  rep.before = fit_runs(pointers(runs), {}, start);
  const MfParams base{
      rep.before.params[0], rep.before.params[1], rep.before.params[2], rep.before.params[3], 0, 0};
  // Two starts for every fit: the baseline (B, C, D, E that absorbed the effect, often the
  // nearest) and a neutral curve from the data (its peak and initial slope, C 1.65, E 0), which
  // the baseline's distortion cannot trap: wheel inertia on the ground pulled the baseline to
  // E 0.92, from where the fit with the effect stopped in a local minimum at 2x the noise.
  const MfParams neutral = neutral_start(runs);
  const Fitter fit = [&](const std::vector<const Run*>& train, const std::vector<Effect>& e) {
    Fit a = fit_runs(train, e, base);
    Fit b = fit_runs(train, e, neutral);
    return b.ssr < a.ssr ? b : a;
  };
  rep.gap_before_rmse_n = heldout(runs, {}, fit);
  rep.where = where_rows(runs, rep.before.params);

  // A cradle cap exists on a roller only.
  std::vector<Effect> candidates;
  for (Effect e : kAllEffects)
    if (e != Effect::CradleCap || runs.front().bench == can::BenchKind::Roller)
      candidates.push_back(e);
  select_effects(rep, runs, candidates, fit, o,
                 "the data cannot separate {} from {} (held-out gains {:.3f} and {:.3f}); runs at "
                 "other speeds or ramp rates would");
  if (cap) {
    // Found from how the runs end, not fitted: before, the baseline on the whole runs (the
    // runaway at the cap included); after, the baseline on the runs below the cap.
    put_cap_first(rep, cap->cap_n, heldout(runs_in, {}, fit));
    rep.notes.push_back(fmt::format(
        "every run ran away at {:.0f} N (spread {:.1f} %) while its force was still rising with "
        "slip ({:.0f} % of the initial slope): the force was capped before the tyre's peak (a "
        "two-roller cradle caps it at Fz sin beta); the samples from 98 % of the cap on (the "
        "runaway) are left out, and B, C, D, E describe the curve only up to that force",
        cap->cap_n, 100 * cap->spread, 100 * cap->end_slope_ratio));
  } else if (const auto it = std::find(rep.accepted.begin(), rep.accepted.end(), Effect::CradleCap);
             it != rep.accepted.end()) {
    std::size_t at = 4;
    for (auto e = rep.accepted.begin(); e != it; ++e) at += effect_params(*e).size();
    rep.cap_n = rep.after.params[at];
  }
  if (std::find(rep.accepted.begin(), rep.accepted.end(), Effect::LoadTransfer) !=
      rep.accepted.end())
    rep.notes.push_back(
        "on one bench the deceleration follows the braking force, so load transfer reshapes the "
        "curve as a function of slip alone: a tyre whose curve is not a Magic Formula can look "
        "like it (checked here: its stiffness ratio is inside its range); roller runs without "
        "deceleration (--roller/--road) separate the two");
  return rep;
}

Report diagnose_transfer(const std::vector<Run>& roller, const std::vector<Run>& road_all,
                         const MfParams& start, const Options& o) {
  if (roller.empty()) throw InputError("bench-vs-bench gap: no usable roller run");
  Report rep;
  // The roller's own effects (relaxation, inertia, threshold, a cradle cap...) would bend its B,
  // C, D, E: with two or more roller runs they are diagnosed first (model vs measurement, roller
  // gates) and the corrected parameters are what the roller says about the tyre.
  Fit roller_fit;  // one roller run: the plain fit (no run to check an effect on)
  double cap_n = NAN;
  if (roller.size() < 2) {
    roller_fit = fit_runs(pointers(roller), {}, start);
  } else {
    const Report own = diagnose(roller, start, calibrated_options(Condition::Roller, o));
    roller_fit = own.after;
    cap_n = own.cap_n;
    std::vector<std::string> names;
    for (const auto& v : own.verdict)
      if (v != "none" && v != "unexplained") names.push_back(v);
    if (!names.empty())
      rep.notes.push_back(fmt::format(
          "the roller runs were corrected for their own {} before their B, C, D, E were carried to "
          "the road",
          fmt::join(names, ", ")));
  }
  const bool capped = std::isfinite(cap_n);
  // The roller fit says nothing beyond what the roller runs reached (a roller test stops near
  // the peak, or at the cap): the road runs are compared up to that slip (or force).
  double max_slip = 0;
  for (const Run& r : roller)
    for (double k : r.slip) max_slip = std::max(max_slip, k);
  std::vector<Run> road;
  std::size_t dropped = 0, total = 0;
  for (const Run& r : road_all) {
    Run cut = capped ? up_to(r, r.force_n, cap_n) : up_to(r, r.slip, max_slip);
    total += r.t_s.size();
    dropped += r.t_s.size() - cut.t_s.size();
    if (cut.t_s.size() >= 20) road.push_back(std::move(cut));
  }
  if (road.size() < 2)
    throw InputError(
        "bench-vs-bench gap needs at least two road runs (each transfer effect is checked on a "
        "road run it was not fitted to) with 20 samples within the roller runs' reach");
  if (dropped > 0)
    rep.notes.push_back(
        capped ? fmt::format("the road runs are compared up to the roller's cap, {:.0f} N ({} of "
                             "{} road samples above it are left out: the roller says nothing "
                             "there)",
                             cap_n, dropped, total)
               : fmt::format("the road runs are compared up to {:.1f} % slip, the largest the "
                             "roller runs reached ({} of {} road samples beyond it are left out: "
                             "the roller fit says nothing there)",
                             100 * max_slip, dropped, total));
  rep.noise_n = noise_of(road);
  const MfParams base{
      roller_fit.params[0], roller_fit.params[1], roller_fit.params[2], roller_fit.params[3], 0, 0};
  const Fitter fit = [&](const std::vector<const Run*>& train, const std::vector<Effect>& e) {
    return fit_effects(train, e, base);  // the roller's B, C, D, E held
  };
  rep.before = fit(pointers(road), {});  // the roller's parameters on the road
  rep.before.stderr_.assign(roller_fit.stderr_.begin(), roller_fit.stderr_.begin() + 4);
  rep.gap_before_rmse_n = heldout(road, {}, fit);
  rep.where = where_rows(road, rep.before.params);
  select_effects(rep, road, {kTransferEffects.begin(), kTransferEffects.end()}, fit, o,
                 "the road runs cannot separate {} from {} (held-out gains {:.3f} and {:.3f})");
  if (capped) {
    // The cradle capped the roller below the tyre's peak: the roller curve is known up to the cap
    // only, and the road above it is no gap of the tyre's. Before: the whole road runs against
    // the roller curve; after: the road up to the cap (where the rest was ranked).
    std::vector<Run> whole;
    for (const Run& r : road_all)
      if (r.t_s.size() >= 20) whole.push_back(r);
    const double up_to_cap = rep.gap_before_rmse_n;
    put_cap_first(rep, cap_n, heldout(whole, {}, fit));
    rep.notes.push_back(fmt::format(
        "the cradle capped the roller at {:.0f} N, below the tyre's peak (Fz sin beta): the roller "
        "shows the tyre only up to that force and the road above it is not a gap of the tyre's "
        "({:.1f} N held out on the whole road runs, {:.1f} N up to the cap)",
        cap_n, rep.gap_before_rmse_n, up_to_cap));
  }
  return rep;
}

}  // namespace brakefit::gap
