// Conditioning: a brake event becomes a Run for the diagnosis (signed Eq. 1 slip, channel
// alignment, smoothing (signal.cpp), derivatives, noise, cuts at the runaway and a locked wheel,
// the start state, decimation). The runs' reference biases are levelled in levelling.cpp.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <tuple>
#include <utility>

#include "core/curve.hpp"
#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"
#include "core/gap/realign.hpp"

namespace brakefit::gap {

namespace {

/// A drooping roller's rebuilt speed, and its droop kept for the runs that could not show it.
void take_droop(Run& r, RollerDroop&& d, double step_mps, double roller_radius_m) {
  r.roller_staircase = std::make_shared<const Run::RollerStaircase>(
      Run::RollerStaircase{r.t_s, r.v_ref_mps, r.force_n, step_mps, roller_radius_m});
  r.v_ref_mps = std::move(d.v_ref_mps);
  r.roller_droop_mps_per_n = d.mps_per_n;
  r.roller_droop_lag_s = d.lag_s;
}

}  // namespace

/// The initial slip rate is fitted over this much of the run's start.
constexpr double kInitialWindowS = 0.04;
/// A quantised roller spanning fewer levels than this is held at speed (a ripple of 5e-4 of
/// 5.5 km/h is 3 steps of 0.5 mm/s peak to peak, the rounding one more).
constexpr double kHeldRollerSteps = 5.0;
/// The brake is at rest below this pressure: a run starts at the event lead-in's last sample
/// under it (the rise from rest tells a dead zone from a slip offset). Not earlier: over 50 ms
/// of rest a pressure channel clipped at zero reads its noise as a mean force, a dead zone of a
/// few 0.01 bar to the fits (generator A's null BIC drops 6.7 -> 25).
constexpr double kRestPressureBar = 0.2;
/// An event whose pressure peaks under this is an air brake's (0-10 bar; a hydraulic brake
/// locks a wheel at tens of bar). Its 0.2 bar is 1.6 kN on a truck's wheel: a run started there
/// begins with a load already on, and a roller's drive drooping behind it read a lag 50 ms
/// short. An air brake rests under this share of its peak.
constexpr double kAirBrakeMaxBar = 10.0;
constexpr double kAirBrakeRestShare = 0.005;

/// A wheel that stepped down this shortly before its run starts, to a level this many
/// quantisation steps below its mean at rest, was braked before the pressure channel showed it (a
/// late channel): its run starts on its way down, not at rest. (An encoder's ripple dithering
/// between two levels puts the mean half a step from either; a free-rolling wheel drifting a
/// level down 98 ms before a dead zone's run is at rest.)
constexpr double kLeftRestSteps = 0.75;
constexpr double kLeftRestWithinS = 0.06;

/// Whether the wheel left its rest level in the lead-in's rest part (see kLeftRestSteps).
static bool left_rest_in_lead_in(std::span<const pipeline::Sample> rest, double step_mps) {
  double sum = 0;
  int n = 0;
  const pipeline::Sample* last_step = nullptr;  // the sample after the last change of level
  const pipeline::Sample* prev = nullptr;
  bool stepped_down = false;
  for (const pipeline::Sample& s : rest) {
    if (!(s.v_ref_mps >= kMinRefSpeedMps) || !std::isfinite(s.v_wheel_mps)) continue;
    sum += s.v_wheel_mps;
    ++n;
    if (prev && s.v_wheel_mps != prev->v_wheel_mps) {
      last_step = &s;
      stepped_down = s.v_wheel_mps < prev->v_wheel_mps;
    }
    prev = &s;
  }
  if (!last_step || !stepped_down) return false;
  return prev->v_wheel_mps < sum / n - kLeftRestSteps * step_mps &&
         static_cast<double>(prev->t_ns - last_step->t_ns) * 1e-9 <= kLeftRestWithinS;
}

/// The smoother's half window spans at most this long: 10 samples at 500 Hz and up; at 100 Hz
/// ten samples (0.1 s each side) would bend a 0.35 s ramp's kinks into structure no effect
/// explains (a null generator C ground set read `unexplained` at a floor of 15 N).
constexpr double kMaxSmoothHalfWindowS = 0.02;
/// At least this many samples each side (a quadratic fit over five points).
constexpr int kMinSmoothHalfWindow = 2;

/// The half window (samples) for a run sampled at t_s: at most `samples`, at most
/// kMaxSmoothHalfWindowS at the run's median sample interval.
static int smoothing_half_window(const std::vector<double>& t_s, int samples) {
  const double interval_s = median_interval_s(t_s);
  if (!(interval_s > 0)) return samples;
  const int in_time = static_cast<int>(std::lround(kMaxSmoothHalfWindowS / interval_s));
  return std::clamp(in_time, std::min(kMinSmoothHalfWindow, samples), samples);
}

Run condition(const std::string& name, const pipeline::Event& e, const pipeline::Calibration& c,
              const ConditionOptions& o) {
  Run full;
  full.name = name;
  full.bench = c.bench;
  full.wheel_radius_m = c.wheel_radius_m;
  full.brake_gain_n_per_bar = c.brake_gain_n_per_bar;
  full.wheel_load_n = c.wheel_load_n;
  std::vector<double> v_wheel, pressure;
  auto take = [&](const pipeline::Sample& s) {
    if (s.v_ref_mps < kMinRefSpeedMps) return;
    const double f = o.force == pipeline::ForceSource::Tester
                         ? s.force_n
                         : c.brake_gain_n_per_bar * s.pressure_bar;
    if (!std::isfinite(f)) return;
    full.t_s.push_back(static_cast<double>(s.t_ns - e.t_start_ns) * 1e-9);
    full.v_ref_mps.push_back(s.v_ref_mps);
    v_wheel.push_back(s.v_wheel_mps);
    pressure.push_back(s.pressure_bar);
    full.force_n.push_back(f);
  };
  // The run starts at the rise from rest: from the lead-in's last sample at rest on.
  double peak_bar = 0;
  for (const auto& s : e.samples) peak_bar = std::max(peak_bar, s.pressure_bar);
  const double rest_bar =
      peak_bar < kAirBrakeMaxBar ? kAirBrakeRestShare * peak_bar : kRestPressureBar;
  std::size_t rest = e.lead_in.size();
  while (rest > 0 && e.lead_in[rest - 1].pressure_bar > rest_bar) --rest;
  for (std::size_t i = rest > 0 ? rest - 1 : e.lead_in.size(); i < e.lead_in.size(); ++i)
    take(e.lead_in[i]);
  measure_rest_slip(full, std::span(e.lead_in).first(rest), rest_bar);
  for (const auto& s : e.samples) take(s);
  if (o.channel_advance_s > 0)
    advance_channel(full.t_s, o.channel_advance_s, {&pressure, &full.force_n},
                    {&full.v_ref_mps, &v_wheel});
  if (const std::size_t keep = runaway_cut(full, v_wheel, c.bench, o); keep < full.t_s.size()) {
    full.t_s.resize(keep);
    full.v_ref_mps.resize(keep);
    v_wheel.resize(keep);
    pressure.resize(keep);
    full.force_n.resize(keep);
  }
  if (full.t_s.size() < kMinRunSamples)
    throw InputError(
        fmt::format("{}: {} samples up to the lock or runaway: too few for a "
                    "diagnosis (at least {})",
                    name, full.t_s.size(), kMinRunSamples));
  const int half_window = smoothing_half_window(full.t_s, o.smooth_half_window);
  // The run's time is the sampler's clock, not each stamp: a tester's stamps are jittered and
  // quantised (0.1-1 ms). Over them the declared pressure filter read a 250 bar/s ramp's stamp
  // errors as force (5 N on B's null ground sets, 2x their floor), and the stamps smoothed kept
  // a scatter that read the deceleration 2 % off mid-run and twice over at the run's end (where
  // the smoother's window shrinks): load transfer seed 101171's stiffness ratio fitted to 0.
  std::vector<double> event_stamps_s;
  for (const auto* part : {&e.lead_in, &e.samples})
    for (const pipeline::Sample& s : *part)
      event_stamps_s.push_back(static_cast<double>(s.t_ns - e.t_start_ns) * 1e-9);
  full.t_s = sampler_clock(full.t_s, half_window, sampler_interval(event_stamps_s, half_window));
  // A first-order filter the tester declared on its pressure channel stays in the data: the
  // model's force is filtered the same way (predict). (Undoing it, p + tau dp/dt, left 3-6 N of
  // structure on noise-free generator B ground runs: the slope is smeared at the ramp's kink.)
  if (o.force == pipeline::ForceSource::Pressure) full.pressure_filter_s = c.pressure_filter_s;
  // A quantised speed channel (a tester's export: 0.5-3 mm/s steps) is a staircase whose error
  // is not white where the speed moves slowly: it is rebuilt from its transitions (where the
  // staircase steps, the speed crossed the middle of the two levels), as an encoder's speed is
  // from its edge times.
  ChannelNoise ref_noise = channel_noise(full.v_ref_mps), wheel_noise = channel_noise(v_wheel);
  // Speeds from encoder frames (frame means of edge-timed counts) are not an export's staircase:
  // their discrete values are the edge clock's, far finer than the speed.
  if (c.speed_timing == "frame_mean") ref_noise.step = wheel_noise.step = 0;
  // The two speeds come from one export at one resolution: a reference that never changed level
  // (a roller held at speed) shows no step of its own but has the wheel's.
  // (A roller's reference flipping between two neighbouring levels is such a channel too.)
  bool ref_smooth = false;  // the reference was read as a smooth speed (not rebuilt)
  if (const double q = std::max(ref_noise.step, wheel_noise.step); q > 0) {
    // (Values, not iterators: the speed may be replaced below. The bound once read freed memory
    // through an iterator and was 300 on a generator B roller set: no bound at all.)
    const auto [lo_it, hi_it] = std::minmax_element(full.v_ref_mps.begin(), full.v_ref_mps.end());
    const double lo = *lo_it, hi = *hi_it;
    const double half_step_ratio = 0.5 * q / std::max(lo, 1e-6);  // a run's slip bias bound
    if (hi - lo < (c.bench == can::BenchKind::Roller ? 1.5 : 0.5) * q) {
      ref_noise.step = q;
      ref_noise.sd = std::max(ref_noise.sd, q / std::sqrt(12.0));
      full.ref_bias_bound = half_step_ratio;
      // A roller is held at speed: its flips between two levels are the encoder's ripple or
      // noise at a level boundary, not speed. It is read as its mean (closer to the truth than
      // either level, and free of the flips' steps).
      // A roller whose drive droops a step under the brake's load is rebuilt with the droop.
      if (c.bench == can::BenchKind::Roller) {
        if (auto droop =
                drooping_roller_speed(full.t_s, full.v_ref_mps, full.force_n, c.roller_radius_m, q);
            !droop.v_ref_mps.empty()) {
          take_droop(full, std::move(droop), q, c.roller_radius_m);
          ref_smooth = true;
        } else {
          double mean = 0;
          for (double v : full.v_ref_mps) mean += v;
          mean /= static_cast<double>(full.v_ref_mps.size());
          std::fill(full.v_ref_mps.begin(), full.v_ref_mps.end(), mean);
          full.roller_held_quantised = true;
        }
      }
    } else if (c.bench == can::BenchKind::Roller && ref_noise.step > 0 &&
               hi - lo < kHeldRollerSteps * q) {
      // A roller held at speed whose encoder's ripple dithers a few levels: rebuilt from its
      // transitions, a ripple of about a step is clipped (52-105 % of it, by where the levels
      // fall) and what is left of it in the slip looks like a lag. The ripple is the encoder's,
      // not the roller's (the roller is held by its motor): the speed is the smooth trend under
      // it, fitted to the staircase.
      // A roller whose drive droops under the brake's load is rebuilt with the droop.
      if (auto droop =
              drooping_roller_speed(full.t_s, full.v_ref_mps, full.force_n, c.roller_radius_m, q);
          !droop.v_ref_mps.empty()) {
        take_droop(full, std::move(droop), q, c.roller_radius_m);
        ref_smooth = true;
      } else if (auto trend = held_roller_speed(full.t_s, full.v_ref_mps, c.roller_radius_m);
                 !trend.empty()) {
        full.v_ref_mps = std::move(trend);
        full.roller_held_quantised = true;
        ref_smooth = true;
      }
      if (ref_smooth) full.ref_bias_bound = half_step_ratio;
    }
  }
  // A roller whose drive droops by many steps: the droop fitted to the transitions, where it is
  // the roller's (the channel's own rebuilding is pinned only at its transitions, up to half a
  // step off between them: 2e-4 of slip at 1.6 m/s).
  if (c.bench == can::BenchKind::Roller && !ref_smooth && ref_noise.step > 0)
    if (auto droop = drooping_roller_speed(full.t_s, full.v_ref_mps, full.force_n,
                                           c.roller_radius_m, ref_noise.step);
        !droop.v_ref_mps.empty()) {
      take_droop(full, std::move(droop), ref_noise.step, c.roller_radius_m);
      ref_smooth = true;
    }
  // A roller's wheel held on one level before it slows (rolling free while the pressure rises
  // through a dead zone): where its level is, and when it first left it (hold_rest_at_foot).
  // Only a level the wheel held at rest: a wheel that left its rest level in the lead-in (its
  // brake bit before the pressure channel showed it, a late channel) starts the run on its way
  // down, and a rest placed at the foot there holds its slip while the force rises (a 44 ms lag
  // left a 100 N kink at each run's start that no effect explains).
  if (c.bench == can::BenchKind::Roller && wheel_noise.step > 0 &&
      !left_rest_in_lead_in(std::span(e.lead_in).first(rest), wheel_noise.step))
    for (std::size_t i = 1; i < v_wheel.size(); ++i)
      if (v_wheel[i] != v_wheel[i - 1]) {
        if (v_wheel[i] < v_wheel[i - 1]) {  // slowing (a first flip upwards is ripple or noise)
          full.held_level_mps = v_wheel.front();
          full.held_step_mps = wheel_noise.step;
          full.held_until_s = 0.5 * (full.t_s[i] + full.t_s[i - 1]);
        }
        break;
      }
  // A rebuilt channel is smooth between its transitions, so its error is not seen as noise: it is
  // where each transition fell inside its sample interval, sd = |dv/dt| dt / sqrt(12) (at most
  // the staircase's step / sqrt(12)), carried into the slip's sd below.
  std::array<std::vector<double>, 2> rebuild_sd_mps;  // reference, wheel
  for (auto [v, cn, sd] : {std::tuple{&full.v_ref_mps, &ref_noise, &rebuild_sd_mps[0]},
                           std::tuple{&v_wheel, &wheel_noise, &rebuild_sd_mps[1]}})
    if (cn->step > 0 && !(v == &full.v_ref_mps && ref_smooth)) {
      *v = dequantise(full.t_s, *v, cn->step);
      *sd = rebuilt_timing_sd(full.t_s, *v, cn->step);
    }
  // A fifth wheel's ripple is read from its own speed (the vehicle slows smoothly), not from the
  // force residual, where it took part of an effect's bend (reference_ripple.cpp).
  if (c.bench == can::BenchKind::Ground)
    if (auto rr = fifth_wheel_ripple(full.t_s, full.v_ref_mps, c.fifth_wheel_radius_m);
        rr && rr->found) {
      full.ref_ripple_from_speed = true;
      full.ref_ripple_amplitude = rr->amplitude;
      full.ref_ripple_c = rr->c;
      full.ref_ripple_s = rr->s;
      full.v_ref_mps = std::move(rr->v_mps);
    }
  // Noise of each channel: robust scale of second differences (the signal is smooth at 1 kHz;
  // first differences would count a 250 bar/s ramp, 16 N per sample, as noise), and at least
  // the quantisation's step/sqrt(12) (a slowly moving quantised signal has mostly zero
  // differences).
  const ChannelNoise force_noise = channel_noise(full.force_n);
  full.noise_n = force_noise.sd;
  full.force_step_n = force_noise.step;
  full.v_ref_sd_mps = ref_noise.sd;
  full.v_ref_step_mps = ref_noise.step;
  full.v_wheel_sd_mps = wheel_noise.sd;
  full.v_wheel_step_mps = wheel_noise.step;
  // Channel alignment: an encoder speed is the mean over the interval since the previous edge
  // time (one frame), so it describes the moment half a frame before its stamp, while the
  // pressure is sampled at the stamp. The speeds are moved forward by half the median interval.
  // (Speeds taken at the stamp, speed_timing = "instant", are not moved.)
  if (c.speed_timing == "frame_mean") {
    const double half = 0.5 * median_interval_s(full.t_s);
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
  // The slip's noise after smoothing, measured on the slip itself (smoothed_noise_sd): the two
  // speeds' errors are not independent (a roller's speed wobble is followed by the wheel and
  // cancels in Eq. 1), and white noise, the anti-correlated error of edge-timed frame means and
  // the correlated error of a rebuilt staircase each count as what they leave. (A constant
  // reference's quantisation is a bias of the run, levelled across runs in the diagnosis.)
  std::vector<double> raw_slip(v_wheel.size());
  for (std::size_t i = 0; i < raw_slip.size(); ++i)
    raw_slip[i] = 1.0 - v_wheel[i] / full.v_ref_mps[i];
  const std::optional<double> measured_sd = smoothed_noise_sd(raw_slip, half_window);
  const double ref_radius_m =
      c.bench == can::BenchKind::Roller ? c.roller_radius_m : c.fifth_wheel_radius_m;
  full.slip_sd_unmeasured = !measured_sd;
  // Too short: the slip at rest before the brake measures the speeds' noise (rest_noise.cpp).
  if (!measured_sd && rest > 1) {
    const double interval_s = median_interval_s(full.t_s);
    const RestGeometry g{
        c.wheel_radius_m, ref_radius_m,     c.speed_timing == "frame_mean" ? 0.5 * interval_s : 0,
        interval_s,       wheel_noise.step, ref_noise.step};
    Run::RestProbe p = rest_probe(std::span(e.lead_in).first(rest), rest_bar, g);
    if (full.ref_ripple_from_speed)
      p = rest_probe_without(p, {{false, true}, {0, full.ref_ripple_c}, {0, full.ref_ripple_s}});
    for (double v : full.v_ref_mps) p.gain_mps += v / static_cast<double>(full.v_ref_mps.size());
    p.gain_mps *= smoothing_noise_gain(half_window);
    full.rest_probe = std::make_shared<const Run::RestProbe>(std::move(p));
    measure_rest_noise(full, {});
  }
  const double slip_sd = measured_sd.value_or(0.0);
  const auto vr = smooth(full.v_ref_mps, half_window), vw = smooth(v_wheel, half_window);
  Run::NoiseProbe probe{half_window, std::move(raw_slip), {}, {}, slip_sd};
  const std::vector<double> v_ref_raw = std::exchange(full.v_ref_mps, vr);
  for (std::size_t i = 0; i < vr.size(); ++i) {
    full.slip.push_back(std::clamp(1.0 - vw[i] / vr[i], -1.0, 1.0));  // below 0: a slip offset
    // slip = 1 - vw / vr: d slip = -d vw / vr + vw d vr / vr^2
    const double ref_part = rebuild_sd_mps[0].empty() ? 0 : vw[i] * rebuild_sd_mps[0][i] / vr[i];
    const double wheel_part = rebuild_sd_mps[1].empty() ? 0 : rebuild_sd_mps[1][i];
    full.slip_sd.push_back(std::hypot(slip_sd, std::hypot(ref_part, wheel_part) / vr[i]));
  }
  // Derivatives take their time from the sampler's clock (above), not from each stamp: two
  // samples that share a stamp are spread half a step apart, and a central difference over
  // such a pair read a fifth wheel's 12.3 m/s^2 as 24.6 (generator B, load transfer seed
  // 101048), which load transfer then read as load.
  full.wheel_accel_mps2 = derivative(full.t_s, vw);
  // The encoders' angles (trapezoidal integration of speed / radius).
  full.wheel_angle_rad.assign(vw.size(), 0.0);
  full.ref_angle_rad.assign(vr.size(), 0.0);
  for (std::size_t i = 1; i < vw.size(); ++i) {
    const double dt = full.t_s[i] - full.t_s[i - 1];
    full.wheel_angle_rad[i] =
        full.wheel_angle_rad[i - 1] + 0.5 * (vw[i] + vw[i - 1]) * dt / c.wheel_radius_m;
    full.ref_angle_rad[i] =
        full.ref_angle_rad[i - 1] + 0.5 * (vr[i] + vr[i - 1]) * dt / ref_radius_m;
  }
  full.encoder_wave = {smoothed_wave(v_wheel, vw, full.wheel_angle_rad, half_window),
                       smoothed_wave(v_ref_raw, vr, full.ref_angle_rad, half_window)};
  if (measured_sd) {
    probe.wheel_angle_rad = full.wheel_angle_rad;
    probe.ref_angle_rad = full.ref_angle_rad;
    full.slip_noise = std::make_shared<const Run::NoiseProbe>(std::move(probe));
  }
  auto dref = derivative(full.t_s, vr);
  for (double& d : dref) d = -d;
  full.ref_decel_mps2 = dref;
  full.pressure_rate_bar_per_s = derivative(full.t_s, smooth(pressure, half_window));
  // Start state: the slip rate (a line through the first kInitialWindowS) and the line's force at
  // the first sample.
  if (const StartLine slip = start_line(full.t_s, full.slip, kInitialWindowS); slip.points >= 3)
    full.initial_slip_rate_per_s = std::max(0.0, slip.slope);
  full.initial_force_n = line_force_at_start(full.t_s, full.force_n, full.pressure_filter_s);
  full.source = std::make_shared<const RunSource>(RunSource{name, e, c, o});
  return decimate(std::move(full), o.max_points);
}

}  // namespace brakefit::gap
