// Taking a fitted once-per-revolution ripple out of a run: out of its slip, out of the wheel's
// acceleration and the reference's deceleration (as its derivative), and out of what the slip's
// noise was measured on, whose noise is then measured again.
#include <algorithm>
#include <cmath>
#include <memory>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"

namespace brakefit::gap {

namespace {

/// The probe's raw slip with the ripple taken out of it.
std::vector<double> raw_slip_without(const Run::NoiseProbe& p, const SpeedRipple& fit) {
  std::vector<double> out = p.raw_slip;
  for (std::size_t i = 0; i < out.size(); ++i)
    out[i] += ripple_slip_fix(fit, p.raw_slip[i], p.wheel_angle_rad[i], p.ref_angle_rad[i]);
  return out;
}

/// Takes a fitted ripple out of a run: a speed read as v (1 + eps(angle)) gives the slip
/// s - (1 - s) eps_wheel + (1 - s) eps_ref, and its derivative carries v eps' (the wheel's
/// acceleration, the reference's deceleration). eps is the wave as the smoother passed it, and
/// its rate the same central difference the conditioning took of the smoothed speed.
void remove_ripple(Run& r, const SpeedRipple& fit) {
  const std::size_t n = r.slip.size();
  std::vector<double> slip_fix(n, 0.0);
  for (std::size_t e = 0; e < 2; ++e) {
    if (!fit.used[e]) continue;
    const Run::Wave wave = encoder_wave(r, e);
    std::vector<double> eps(n);
    for (std::size_t i = 0; i < n; ++i) eps[i] = fit.c[e] * wave.cos[i] + fit.s[e] * wave.sin[i];
    const std::vector<double> eps_rate = derivative(r.t_s, eps);
    std::vector<double>& d = e == 0 ? r.wheel_accel_mps2 : r.ref_decel_mps2;
    const double sign = e == 0 ? 1.0 : -1.0;  // d is +d v_wheel / dt, -d v_ref / dt
    for (std::size_t i = 0; i < n; ++i) {
      const double v_mps = e == 0 ? r.v_ref_mps[i] * (1 - r.slip[i]) : r.v_ref_mps[i];
      if (i < d.size()) d[i] = d[i] * (1 - eps[i]) - sign * v_mps * eps_rate[i];
      slip_fix[i] += sign * (1 - r.slip[i]) * eps[i];
    }
  }
  // s_measured = s - (1 - s) eps_wheel + (1 - s) eps_ref: the ripple is added back.
  for (std::size_t i = 0; i < n; ++i) r.slip[i] += slip_fix[i];
}

}  // namespace

double ripple_slip_fix(const SpeedRipple& ripple, double slip, double wheel_angle_rad,
                       double ref_angle_rad) {
  double fix = 0;
  for (std::size_t e = 0; e < 2; ++e) {
    if (!ripple.used[e]) continue;
    const double ang = e == 0 ? wheel_angle_rad : ref_angle_rad;
    const double eps = ripple.c[e] * std::cos(ang) + ripple.s[e] * std::sin(ang);
    fix += (e == 0 ? 1.0 : -1.0) * (1 - slip) * eps;
  }
  return fix;
}

Run::Wave smoothed_wave(const std::vector<double>& v, const std::vector<double>& v_smooth,
                        const std::vector<double>& angle_rad, int half_window) {
  const std::size_t n = v.size();
  std::vector<double> vc(n), vs(n);
  for (std::size_t i = 0; i < n; ++i) {
    vc[i] = v[i] * std::cos(angle_rad[i]);
    vs[i] = v[i] * std::sin(angle_rad[i]);
  }
  Run::Wave w{smooth(vc, half_window), smooth(vs, half_window)};
  for (std::size_t i = 0; i < n; ++i) {
    // At rest (no speed) the ripple has no size: the unsmoothed wave keeps the columns finite.
    if (std::abs(v_smooth[i]) > 1e-6) {
      w.cos[i] /= v_smooth[i];
      w.sin[i] /= v_smooth[i];
    } else {
      w.cos[i] = std::cos(angle_rad[i]);
      w.sin[i] = std::sin(angle_rad[i]);
    }
  }
  return w;
}

Run::Wave unsmoothed_wave(const std::vector<double>& angle_rad, double frequency_scale) {
  Run::Wave w;
  for (const double a : angle_rad) {
    w.cos.push_back(std::cos(frequency_scale * a));
    w.sin.push_back(std::sin(frequency_scale * a));
  }
  return w;
}

Run::Wave encoder_wave(const Run& r, std::size_t e) {
  const std::size_t n = r.t_s.size();
  if (const Run::Wave& w = r.encoder_wave[e]; w.cos.size() == n && w.sin.size() == n) return w;
  Run::Wave w = unsmoothed_wave(e == 0 ? r.wheel_angle_rad : r.ref_angle_rad);
  w.cos.resize(n, 1.0);  // a run without angles: a wave of no phase, at no point read
  w.sin.resize(n, 0.0);
  return w;
}

void take_out_ripple(Run& r, const SpeedRipple& ripple, ProbeAfter probe_after) {
  remove_ripple(r, ripple);
  if (r.rest_probe) {
    if (probe_after == ProbeAfter::WithoutRipple) {
      r.rest_probe =
          std::make_shared<const Run::RestProbe>(rest_probe_without(*r.rest_probe, ripple));
      measure_rest_noise(r, {});
    } else {
      measure_rest_noise(r, ripple);
    }
  }
  if (!r.slip_noise) return;
  // The slip's noise was measured with the ripple in it: its measured part is replaced by the
  // noise measured without it.
  std::vector<double> raw = raw_slip_without(*r.slip_noise, ripple);
  const double before = r.slip_noise->sd;
  const double after = smoothed_noise_sd(raw, r.slip_noise->half_window).value_or(before);
  for (double& sd : r.slip_sd)
    sd = std::sqrt(std::max(sd * sd - before * before + after * after, 0.0));
  if (probe_after == ProbeAfter::WithoutRipple) {
    auto probe = std::make_shared<Run::NoiseProbe>(*r.slip_noise);
    probe->raw_slip = std::move(raw);
    probe->sd = after;
    r.slip_noise = std::move(probe);
  }
}

void take_out_reference_ripple(Run& r, double c, double s) {
  SpeedRipple fit;
  fit.used = {false, true};
  fit.c[1] = c;
  fit.s[1] = s;
  // Placed once, before the encoders' estimates start from the slip as it leaves here: the
  // probe keeps it out too.
  take_out_ripple(r, fit, ProbeAfter::WithoutRipple);
}

}  // namespace brakefit::gap
