// Generator B's physics: one run of a set integrated (the wheel, the reference, the transient
// slip) and exported as an event CSV through the station's channels.
#include "sim/second/generator.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>

#include "core/curve.hpp"
#include "core/pipeline/event_csv.hpp"

namespace brakefit::sim2 {

namespace {

constexpr double kG = 9.81;

/// The integrated state: wheel speed, reference (vehicle or roller) speed, transient slip.
using State = std::array<double, 3>;

struct Dynamics {
  const RunCase& c;
  double v_roller_mps = 0;     ///< roller surface speed (roller bench)
  double decel_mps2 = 0;       ///< the deceleration the load follows (behind the body's pitch)
  double decel_rate_mps3 = 0;  ///< its rate, the pitch mode's second state
  double slid_m = 0;           ///< energy slid per unit load so far (friction_fade)

  double line_pressure_bar(double t_s) const {
    const double t0 = c.tester.leading_s;
    return t_s <= t0 ? 0.0 : std::min(c.max_pressure_bar, c.ramp_bar_per_s * (t_s - t0));
  }
  double fz_n() const { return c.fz_n * std::max(0.2, 1.0 + c.load_per_decel * decel_mps2); }
  double ref_speed(const State& y) const {
    return c.bench == can::BenchKind::Roller ? v_roller_mps : y[1];
  }
  double tyre_force_n(double kappa, double v_mps) const {
    // Held over an integration step: the fade moves with the energy slid, far slower.
    const double fade = c.fade_per_m > 0 ? 1.0 / (1.0 + c.fade_per_m * slid_m) : 1.0;
    if (c.brush) return fade * brush_braking_force_n(c.brush_tyre, kappa, fz_n(), v_mps);
    Contact k;
    k.fz_n = fz_n();
    k.pressure_pa = c.pressure_pa;
    k.slip_speed_mps = std::abs(kappa) * v_mps;
    k.lmuv = c.lmuv;
    return fade * mf61_braking_force_n(c.tyre, kappa, k);
  }
  double slip(const State& y) const {
    const double v = ref_speed(y);
    return v > 1e-3 ? 1.0 - y[0] * c.radius_m / v : 0.0;
  }
  /// Force on the tyre: at the transient slip when the tyre relaxes.
  double contact_slip(const State& y) const { return c.relaxation_m > 0 ? y[2] : slip(y); }
  double other_brakes_n(double p_bar) const {
    // The other three wheels brake with the same line pressure (their gain relative to this
    // wheel's), each limited by its friction: the deceleration is not this wheel's force / mass.
    const double want = c.other_brakes_ratio * c.brake_gain_nm_per_bar / c.radius_m * p_bar;
    const double limit = c.other_mu * (c.mass_kg * kG - c.fz_n);
    return std::min(want, limit);
  }
  State deriv(double t_s, const State& y) const {
    State d{0, 0, 0};
    const double v = ref_speed(y);
    const double p = line_pressure_bar(t_s);
    const double kc = contact_slip(y);
    const double f = tyre_force_n(kc, v);
    const double tb = c.brake_gain_nm_per_bar * std::max(0.0, p - c.threshold_bar);
    d[0] = (f * c.radius_m - tb) / c.inertia_kgm2;
    if (y[0] <= 0 && d[0] < 0) d[0] = 0;  // locked
    if (c.bench == can::BenchKind::Ground) d[1] = -(f + other_brakes_n(p)) / c.mass_kg;
    if (c.relaxation_m > 0) d[2] = v / c.relaxation_m * (slip(y) - y[2]);
    return d;
  }
};

State add(const State& a, const State& b, double h) {
  return {a[0] + h * b[0], a[1] + h * b[1], a[2] + h * b[2]};
}

/// One classic RK4 step.
State rk4(const Dynamics& d, double t, const State& y, double h) {
  const State k1 = d.deriv(t, y);
  const State k2 = d.deriv(t + h / 2, add(y, k1, h / 2));
  const State k3 = d.deriv(t + h / 2, add(y, k2, h / 2));
  const State k4 = d.deriv(t + h, add(y, k3, h));
  State out;
  for (std::size_t i = 0; i < 3; ++i)
    out[i] = y[i] + h / 6 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]);
  return out;
}

double quantise(double x, double step) {
  return step > 0 ? std::round(x / step) * step : x;
}

}  // namespace

std::string simulate_event_csv(const RunCase& c) {
  Rng rng(c.seed);
  Dynamics dyn{c};
  const double v0 = c.speed_kmh / 3.6;
  dyn.v_roller_mps = v0;
  // The wheel has rolled freely before the test (the tester spins it up): it starts at the slip
  // where the tyre's force is zero (MF 6.1's shifts put it a few 1e-4 off zero), not at zero
  // slip. Started at zero slip, a relaxing tyre on a light wheel rang: a mode of sqrt(Kx R^2 /
  // (I sigma)), 120 Hz at 0.03 kg m^2 and 0.4 m, damped only by V / (2 sigma), whose +-9 % of
  // slip lasted into the ramp (the diagnosis then found no linear region to work with).
  double k_lo = -0.02, k_hi = 0.02;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (k_lo + k_hi);
    (dyn.tyre_force_n(mid, v0) > 0 ? k_hi : k_lo) = mid;
  }
  const double k_free = 0.5 * (k_lo + k_hi);
  State y{v0 * (1.0 - k_free) / c.radius_m, v0, k_free};
  // Adaptive step: RK4 is stable for h |lambda| < 2.8; lambda = Kx R^2 / (I V) without relaxation
  // (the wheel against the tyre's slip stiffness), V / sigma for the transient slip.
  Contact k0;
  k0.fz_n = c.fz_n;
  k0.pressure_pa = c.pressure_pa;
  const double kx = c.brush ? c.brush_tyre.cx_n : mf61_slip_stiffness_n(c.tyre, k0);
  auto step_for = [&](double v) {
    const double vv = std::max(v, 0.5);
    double lam = c.relaxation_m > 0 ? vv / c.relaxation_m
                                    : kx * c.radius_m * c.radius_m / (c.inertia_kgm2 * vv);
    lam = std::max(lam, 1.0);
    return std::min(1e-4, 1.0 / lam);
  };
  const TesterExport& tx = c.tester;
  const double dt_sample = 1.0 / tx.sample_hz;
  const double phase_ref = rng.uniform(0, 2 * M_PI), phase_wheel = rng.uniform(0, 2 * M_PI);
  double angle_ref = 0, angle_wheel = 0;  // rolled distance / radius of each encoder
  const double ref_radius = c.bench == can::BenchKind::Roller ? 0.1 : 0.2;  // roller, fifth wheel
  // The pressure chain: the line pressure, delayed (time offset), filtered, noisy, quantised.
  double p_filtered = 0;
  std::deque<std::pair<double, double>> slip_window;  // the tester's own slip filter
  pipeline::Event ev;
  ev.bench = c.bench;
  double t = 0, next_sample = 0;
  const double t_max = tx.leading_s + c.max_pressure_bar / c.ramp_bar_per_s + 10.0;
  while (t < t_max) {
    // Integrate to the next sample instant.
    const double target = next_sample;
    while (t < target - 1e-12) {
      const double h = std::min(step_for(dyn.ref_speed(y)), target - t);
      const State before = y;
      y = rk4(dyn, t, y, h);
      if (y[0] < 0) y[0] = 0;
      const double v_ref = dyn.ref_speed(y);
      if (c.bench == can::BenchKind::Roller && c.roller_droop_ratio > 0) {
        const double f = dyn.tyre_force_n(dyn.contact_slip(y), v_ref);
        const double v_target = v0 * (1.0 - c.roller_droop_ratio * f / c.roller_droop_ref_n);
        dyn.v_roller_mps += (v_target - dyn.v_roller_mps) * h / (c.roller_droop_tau_s + h);
      }
      if (c.fade_per_m > 0) {
        const double kc = dyn.contact_slip(y);
        dyn.slid_m += std::abs(dyn.tyre_force_n(kc, v_ref) * kc * v_ref) / c.fz_n * h;
      }
      if (c.bench == can::BenchKind::Ground) {
        // The load follows the body's pitch: the deceleration through a first-order lag, or a
        // damped pitch mode (semi-implicit Euler: at a step of 0.1 ms and 1.5 Hz, h w = 1e-3).
        const double decel = std::max(0.0, (before[1] - y[1]) / h);
        if (c.pitch_hz > 0) {
          const double w = 2 * M_PI * c.pitch_hz;
          dyn.decel_rate_mps3 += h * (w * w * (decel - dyn.decel_mps2) -
                                      2 * c.pitch_damping * w * dyn.decel_rate_mps3);
          dyn.decel_mps2 += h * dyn.decel_rate_mps3;
        } else
          dyn.decel_mps2 += c.pitch_lag_s > 0 ? (decel - dyn.decel_mps2) * h / (c.pitch_lag_s + h)
                                              : decel - dyn.decel_mps2;
      }
      angle_ref += v_ref * h / ref_radius;
      angle_wheel += y[0] * h;
      t += h;
      const double p_late = dyn.line_pressure_bar(std::max(0.0, t - c.time_offset_s));
      const double a = tx.pressure_filter_s > 0 ? 1.0 - std::exp(-h / tx.pressure_filter_s) : 1.0;
      p_filtered += a * (p_late - p_filtered);
    }
    // The sample: what the tester's encoders and transducer report.
    const double v_ref_true = dyn.ref_speed(y);
    const double v_ref =
        quantise(v_ref_true * (1 + tx.eccentricity_ref * std::sin(angle_ref + phase_ref)),
                 tx.speed_step_mps);
    const double v_wheel_true = y[0] * c.radius_m * (1 + c.radius_error_ratio);
    const double v_wheel =
        quantise(v_wheel_true * (1 + tx.eccentricity_wheel * std::sin(angle_wheel + phase_wheel)),
                 tx.speed_step_mps);
    const double p_fs = c.max_pressure_bar, p_read = std::clamp(p_filtered / p_fs, 0.0, 1.0);
    const double bow_bar = 4 * tx.pressure_bow_ratio * p_fs * p_read * (1 - p_read);
    const double p_meas =
        std::max(0.0, quantise(p_filtered + bow_bar + tx.pressure_noise_bar * rng.normal(),
                               tx.pressure_step_bar));
    // The stamp: jittered, on the tester's clock.
    const double stamp = quantise(std::max(0.0, t + tx.jitter_ratio * dt_sample * rng.normal()),
                                  tx.stamp_resolution_s);
    pipeline::Sample s;
    s.t_ns = std::llround(stamp * 1e9);
    if (!ev.samples.empty() && s.t_ns < ev.samples.back().t_ns) s.t_ns = ev.samples.back().t_ns;
    s.v_ref_mps = v_ref;
    s.v_wheel_mps = v_wheel;
    s.pressure_bar = p_meas;
    ev.samples.push_back(s);
    // The tester's own decision on its filtered slip: it stops exporting there.
    const double k_meas = v_ref > 0 ? 1 - v_wheel / v_ref : 0;
    slip_window.emplace_back(t, k_meas);
    while (slip_window.front().first < t - tx.slip_filter_s) slip_window.pop_front();
    double k_f = 0;
    for (const auto& [tt, k] : slip_window) k_f += k;
    k_f /= static_cast<double>(slip_window.size());
    if (t > tx.leading_s) {
      if (c.bench == can::BenchKind::Roller && k_f >= tx.switch_off_slip) break;
      if (c.bench == can::BenchKind::Ground && (k_f >= tx.lock_slip || v_ref_true < 1.0)) break;
    }
    next_sample += dt_sample;
  }
  if (ev.samples.size() > 1 && tx.sample_hz > 0) ev.samples.pop_back();  // the switch-off sample
  ev.end_reason = c.bench == can::BenchKind::Roller ? "tester_switch_off" : "tester_lock";
  pipeline::Calibration cal;
  cal.bench = c.bench;
  cal.wheel_radius_m = c.radius_m;
  cal.wheel_load_n = c.fz_n;
  cal.brake_gain_n_per_bar = std::round(c.brake_gain_nm_per_bar / c.radius_m * 10) / 10;
  cal.tyre_pressure_bar = c.pressure_pa / 1e5;
  cal.speed_kmh = c.speed_kmh;
  cal.speed_timing = "instant";  // the tester samples its speeds at the stamp
  // The export declares its pressure filter (a tester's software documents it).
  cal.pressure_filter_s = std::round(tx.pressure_filter_s * 1e4) / 1e4;
  return pipeline::format_event_csv(ev, cal);
}

}  // namespace brakefit::sim2
