#include "sim/simulator.hpp"

#include <algorithm>
#include <cmath>
#include <deque>
#include <nlohmann/json.hpp>

#include "brakefit/version.hpp"
#include "core/rng.hpp"

namespace brakefit::sim {

namespace {

constexpr std::int64_t kLogEpochUs = 1700000000LL * 1000000LL;  // recordings start 2023-11-14
constexpr int kLoadTransferIterations = 4;       // Fz = W + g F: a contraction while g dF/dFz < 1
constexpr double kNegligibleInertia = 0.05;      // kg m^2, "wheel_inertia = false"
constexpr double kPressureFullScaleBar = 160.0;  // the transducer's range (pressure_bow_ratio)
constexpr double kIdealPpr = 1e6;

/// Quadrature encoder after x4 decoding: cumulative count and the time of the last edge.
struct Encoder {
  double counts_per_rad = 0.0;
  double angle_rad = 0.0;
  std::int64_t count = 0;
  double last_edge_s = 0.0;
  std::uint8_t counter = 0;
  void advance(double omega, double t0, double dt) {
    const double a0 = angle_rad, a1 = angle_rad + omega * dt;
    const auto c1 = static_cast<std::int64_t>(std::floor(a1 * counts_per_rad));
    if (c1 != count && a1 != a0) {
      const double edge_angle = static_cast<double>(c1 > count ? c1 : c1 + 1) / counts_per_rad;
      last_edge_s = t0 + dt * std::clamp((edge_angle - a0) / (a1 - a0), 0.0, 1.0);
      count = c1;
    }
    angle_rad = a1;
  }
  can::LoggedFrame frame(can::Channel ch, std::int64_t t_us) {
    can::EncoderMsg m;
    m.channel = ch;
    m.count_x4_mod = static_cast<std::uint32_t>(count & 0xFFFFFF);
    m.edge_time_us = static_cast<std::uint32_t>(std::llround(last_edge_s * 1e6) & 0xFFFFFFFFLL);
    m.counter = counter++;
    return {t_us, "can0", can::encode(m)};
  }
};

double braking_force(const TyreMf61& tyre, const TyreState& st, double slip) {
  return -fx_mf61(tyre, st, -slip);
}

}  // namespace

SimResult simulate(const Scenario& s) {
  const Effects& e = s.effects;
  SimResult r;
  r.effects = e.active();
  Rng rng(s.seed);
  const bool roller = s.bench == can::BenchKind::Roller;
  const double dt = s.dt_s;
  const auto steps_per_frame = std::max<long>(1, std::lround(1.0 / (s.frame_rate_hz * dt)));
  const double ppr = e.encoder_ppr > 0 ? e.encoder_ppr : kIdealPpr;
  const double inertia = e.wheel_inertia ? s.wheel_inertia_kgm2 : kNegligibleInertia;
  const double rw = s.rolling_radius_m, rr = s.roller_diameter_m / 2;

  TyreState tyre_state;
  tyre_state.fz_n = s.wheel_load_n;
  tyre_state.pressure_bar = s.tyre_pressure_bar;
  tyre_state.lambda_mu = roller ? e.roller_friction : 1.0;
  tyre_state.lambda_mu_v = e.speed_friction;
  tyre_state.shifts = e.slip_offset;
  r.truth = pac96_equivalent(s.tyre, tyre_state);
  TyreState road = tyre_state;
  road.lambda_mu = 1.0;
  r.tyre_road = pac96_equivalent(s.tyre, road);

  auto& cal = r.calibration;
  cal.bench = s.bench;
  cal.roller_radius_m = rr;
  cal.wheel_radius_m = rw * (1.0 + e.wheel_radius_error_ratio);
  cal.fifth_wheel_radius_m = s.fifth_wheel_radius_m;
  cal.roller_ppr = cal.wheel_ppr = cal.fifth_wheel_ppr = ppr;
  cal.brake_gain_n_per_bar = s.brake_gain_nm_per_bar / rw;
  cal.wheel_load_n = s.wheel_load_n;
  cal.tyre_pressure_bar = s.tyre_pressure_bar;
  cal.speed_kmh = roller ? s.roller_speed_kmh : s.ground_speed_kmh;
  cal.switch_off_slip_ratio = s.switch_off_slip_ratio;

  // State.
  const double v0 = (roller ? s.roller_speed_kmh : s.ground_speed_kmh) / 3.6;
  const double omega_set = v0 / rr;
  double omega_r = omega_set;  // roller
  double v_vehicle = v0;       // ground
  double omega_w = v0 / rw;
  double kappa_t = 0.0;  // transient slip (relaxation)
  double p_sensor = 0.0, motor_integral = 0.0, tester_force = 0.0;
  double slid_m = 0.0;  // energy slid per unit load (friction fade)
  const double mu_unfaded = tyre_state.lambda_mu;
  const double counts_per_rev = 4.0 * ppr;
  Encoder enc_ref{counts_per_rev / (2 * M_PI)}, enc_wheel{counts_per_rev / (2 * M_PI)};
  std::deque<double> pressure_history;  // for the channel time offset
  const auto offset_steps = static_cast<std::size_t>(std::lround(e.time_offset_s / dt));
  const double t_brake = roller ? 1.0 : 0.5;
  const double t_max = roller ? 60.0 : 20.0;
  double t_end_phase = -1.0;  // when the test ended (switch-off / stop)
  double p_at_end = 0.0, lock_since = -1.0;
  can::TestState state = can::TestState::Running;
  std::uint8_t p_counter = 0, f_counter = 0, s_counter = 0;

  for (long step = 0;; ++step) {
    const double t = static_cast<double>(step) * dt;
    // Pedal: ramp from t_brake until the test ends, then release at 100 bar/s.
    double p_line = 0.0;
    if (t >= t_brake)
      p_line = t_end_phase < 0 ? s.ramp_bar_per_s * (t - t_brake)
                               : std::max(0.0, p_at_end - 100.0 * (t - t_end_phase));
    if (!roller && t_end_phase >= 0 && r.end_reason == "wheel_lock")
      p_line = p_at_end;  // hold the locked wheel
    pressure_history.push_back(p_line);
    if (pressure_history.size() > offset_steps + 1) pressure_history.pop_front();
    const double p_delayed = pressure_history.front();
    p_sensor = e.pressure_lag_s > 0 ? p_sensor + dt / e.pressure_lag_s * (p_delayed - p_sensor)
                                    : p_delayed;

    // Kinematics and slip.
    const double v_ref = roller ? omega_r * rr : v_vehicle;
    const double v_wheel = omega_w * rw;
    const double kappa = v_ref > 0.05 ? std::clamp((v_ref - v_wheel) / v_ref, -1.0, 1.0)
                                      : (v_wheel < v_ref ? 1.0 : 0.0);
    tyre_state.slip_speed_mps = std::abs(kappa_t) * v_ref;
    if (e.fade_per_m > 0) tyre_state.lambda_mu = mu_unfaded / (1.0 + e.fade_per_m * slid_m);
    // Relaxation: sigma dk'/dt + V k' = V k, implicit in k'.
    const double a = e.relaxation_length_m > 0 ? dt * v_ref / e.relaxation_length_m : INFINITY;
    const double w = std::isinf(a) ? 1.0 : a / (1.0 + a);
    const double kappa_new = std::isinf(a) ? kappa : (kappa_t + a * kappa) / (1.0 + a);
    // Two-roller cradle: past Fz sin(beta) the unrestrained wheel climbs the rear roller and the
    // braking force stays at that cap, whatever the friction (physics.md section 3).
    const double cap_n =
        roller && e.cradle_cap_ratio > 0 ? e.cradle_cap_ratio * s.wheel_load_n : INFINITY;
    // Load transfer: the wheel's load follows the deceleration its own force causes,
    // Fz = W + g F. Solved within the step: a load one step behind its force is an explicit
    // loop that rings with a light wheel and a relaxation length (it vanishes as dt shrinks).
    const double load_per_force = !roller && e.load_transfer
                                      ? s.cg_height_m / s.wheelbase_m / 2.0 / s.wheel_brake_share
                                      : 0.0;
    if (load_per_force > 0)
      for (int k = 0; k < kLoadTransferIterations; ++k)
        tyre_state.fz_n =
            s.wheel_load_n +
            load_per_force * std::max(0.0, braking_force(s.tyre, tyre_state, kappa_new));
    const double tyre_force = braking_force(s.tyre, tyre_state, kappa_new);
    const double force = std::min(tyre_force, cap_n);
    constexpr double h = 1e-6;
    double dF_dk = tyre_force >= cap_n ? 0.0
                                       : (braking_force(s.tyre, tyre_state, kappa_new + h) -
                                          braking_force(s.tyre, tyre_state, kappa_new - h)) /
                                             (2 * h);
    if (load_per_force > 0 && tyre_force < cap_n) {
      // The slip's change moves the load too: dF/dk (1 + g dF/dFz + ...).
      TyreState up = tyre_state, down = tyre_state;
      const double dfz = 1e-3 * s.wheel_load_n;
      up.fz_n += dfz;
      down.fz_n -= dfz;
      const double loop =
          load_per_force *
          (braking_force(s.tyre, up, kappa_new) - braking_force(s.tyre, down, kappa_new)) /
          (2 * dfz);
      if (loop < 0.9) dF_dk /= 1.0 - loop;
    }
    const double dF_domega = v_ref > 0.05 ? dF_dk * w * (-rw / v_ref) : 0.0;
    const double tb = s.brake_gain_nm_per_bar * std::max(0.0, p_line - e.brake_threshold_bar);
    // Wheel: I w' = F R - Tb, linearly implicit in w (stable for stiff tyres), locked at 0.
    const double denom = std::max(1.0, 1.0 - dt * rw * dF_domega / inertia);
    omega_w = std::max(0.0, omega_w + dt * (force * rw - tb) / inertia / denom);
    kappa_t = kappa_new;
    slid_m += std::abs(force * kappa_new * v_ref) / tyre_state.fz_n * dt;
    r.peak_force_n = std::max(r.peak_force_n, force);
    if (roller) {
      // Motor PI speed control while running; off after switch-off.
      double torque = 0.0;
      if (t_end_phase < 0) {
        const double err = omega_set - omega_r;
        motor_integral += err * dt;
        torque = std::clamp(400.0 * err + 4000.0 * motor_integral, 0.0, 2000.0);
      }
      omega_r = std::max(0.0, omega_r + dt * (torque - force * rr) / s.roller_inertia_kgm2);
      // The tester reads the brake force at the roller surface (reaction), through its own lag.
      tester_force = e.tester_force_lag_s > 0
                         ? tester_force + dt / e.tester_force_lag_s * (force - tester_force)
                         : force;
    } else {
      const double decel = std::max(0.0, force / (s.wheel_brake_share * s.vehicle_mass_kg));
      v_vehicle = std::max(0.0, v_vehicle - dt * decel);
    }
    enc_ref.advance(roller ? omega_r : v_vehicle / s.fifth_wheel_radius_m, t, dt);
    enc_wheel.advance(omega_w, t, dt);

    // Test logic.
    if (t >= t_brake && state == can::TestState::Running) state = can::TestState::Measuring;
    if (t_end_phase < 0 && state == can::TestState::Measuring) {
      if (roller && kappa >= s.switch_off_slip_ratio) {
        r.end_reason = "switch_off_slip";
      } else if (!roller) {
        lock_since = kappa >= 0.98 ? (lock_since < 0 ? t : lock_since) : -1.0;
        if (lock_since >= 0 && t - lock_since > 0.05) r.end_reason = "wheel_lock";
        if (v_vehicle < 0.5) r.end_reason = "stopped";
      }
      if (t > t_max) r.end_reason = "timeout";
      if (!r.end_reason.empty()) {
        t_end_phase = t;
        p_at_end = p_line;
        r.end_t_s = t;
        state = r.end_reason == "timeout" ? can::TestState::Aborted : can::TestState::SwitchedOff;
      }
    }
    const double t_next = t + dt;
    const bool done =
        t_end_phase >= 0 &&
        (roller ? t_next > t_end_phase + 1.0 : (v_vehicle < 0.3 || t_next > t_end_phase + 3.0));

    // Frames at the frame rate, stamped at the end of the step.
    if ((step + 1) % steps_per_frame == 0 || done) {
      const std::int64_t t_us = kLogEpochUs + std::llround(t_next * 1e6);
      r.frames.push_back(
          enc_ref.frame(roller ? can::Channel::Roller : can::Channel::FifthWheel, t_us));
      r.frames.push_back(enc_wheel.frame(can::Channel::Wheel, t_us));
      can::PressureMsg pm;
      const double x = std::clamp(p_sensor / kPressureFullScaleBar, 0.0, 1.0);
      const double bow_bar = 4 * e.pressure_bow_ratio * kPressureFullScaleBar * x * (1 - x);
      pm.pressure_bar =
          std::max(0.0, p_sensor + bow_bar +
                            (e.pressure_noise_bar > 0 ? e.pressure_noise_bar * rng.normal() : 0.0));
      pm.counter = p_counter++;
      pm.sample_time_us = static_cast<std::uint32_t>(std::llround(t_next * 1e6) & 0xFFFFFFFFLL);
      r.frames.push_back({t_us, "can0", can::encode(pm)});
      if (roller) {
        can::TesterForceMsg fm;
        fm.brake_force_n = tester_force;
        fm.counter = f_counter++;
        fm.sample_time_us = pm.sample_time_us;
        r.frames.push_back({t_us, "can0", can::encode(fm)});
      }
      if ((step + 1) % (steps_per_frame * 10) == 0 || done) {  // test state at a tenth of the rate
        can::TestStateMsg sm;
        sm.state = state;
        sm.bench = s.bench;
        sm.counter = s_counter++;
        sm.set_speed_kmh = roller ? s.roller_speed_kmh : s.ground_speed_kmh;
        r.frames.push_back({t_us, "can0", can::encode(sm)});
      }
    }
    if (done) {
      r.duration_s = t_next;
      break;
    }
  }
  return r;
}

std::string truth_json(const Scenario& s, const SimResult& r, const std::string& scenario_text) {
  using nlohmann::ordered_json;
  auto params = [](const MfParams& p) {
    return ordered_json{{"B", p.B}, {"C", p.C},     {"D", p.D},
                        {"E", p.E}, {"SHx", p.SHx}, {"SVx", p.SVx}};
  };
  ordered_json j;
  j["schema"] = "brakefit.truth/1";
  j["version"] = kVersion;
  j["bench"] = can::to_string(s.bench);
  j["seed"] = s.seed;
  j["pedal_ramp"] = s.pedal_ramp;
  j["ramp_bar_per_s"] = s.ramp_bar_per_s;
  j["tyre_pressure_bar"] = s.tyre_pressure_bar;
  j["wheel_load_n"] = s.wheel_load_n;
  j["effects"] = r.effects;
  j["pac96_equivalent"] = params(r.truth);
  j["pac96_equivalent_road"] = params(r.tyre_road);
  j["slip_convention"] = "positive braking slip ratio and force; B per unit slip ratio";
  j["end_reason"] = r.end_reason;
  j["end_t_s"] = r.end_t_s;
  j["peak_tyre_force_n"] = r.peak_force_n;
  j["frames"] = r.frames.size();
  j["scenario_toml"] = scenario_text;
  return j.dump(2) + "\n";
}

}  // namespace brakefit::sim
