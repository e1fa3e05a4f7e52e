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

/// d angle / dt at each point (central differences of the rolled angle, one-sided at the ends).
std::vector<double> angle_rate(const std::vector<double>& t_s, const std::vector<double>& angle) {
  const std::size_t n = t_s.size();
  std::vector<double> w(n, 0.0);
  for (std::size_t i = 0; i < n && n > 1; ++i) {
    const std::size_t a = i == 0 ? 0 : i - 1, b = i + 1 == n ? n - 1 : i + 1;
    w[i] = (angle[b] - angle[a]) / std::max(t_s[b] - t_s[a], 1e-9);
  }
  return w;
}

/// The slip's ripple correction (1 - s) (eps_wheel - eps_ref) at the encoders' angles.
double ripple_fix(const SpeedRipple& fit, double slip, double wheel_angle_rad,
                  double ref_angle_rad) {
  double fix = 0;
  for (std::size_t e = 0; e < 2; ++e) {
    if (!fit.used[e]) continue;
    const double ang = e == 0 ? wheel_angle_rad : ref_angle_rad;
    const double eps = fit.c[e] * std::cos(ang) + fit.s[e] * std::sin(ang);
    fix += (e == 0 ? 1.0 : -1.0) * (1 - slip) * eps;
  }
  return fix;
}

/// The probe's raw slip with the ripple taken out of it.
std::vector<double> raw_slip_without(const Run::NoiseProbe& p, const SpeedRipple& fit) {
  std::vector<double> out = p.raw_slip;
  for (std::size_t i = 0; i < out.size(); ++i)
    out[i] += ripple_fix(fit, p.raw_slip[i], p.wheel_angle_rad[i], p.ref_angle_rad[i]);
  return out;
}

/// Takes a fitted ripple out of a run: a speed read as v (1 + eps(angle)) gives the slip
/// s - (1 - s) eps_wheel + (1 - s) eps_ref, and its derivative carries v eps' (the wheel's
/// acceleration, the reference's deceleration).
void remove_ripple(Run& r, const SpeedRipple& fit) {
  const std::size_t n = r.slip.size();
  for (std::size_t e = 0; e < 2; ++e) {
    if (!fit.used[e]) continue;
    const std::vector<double>& angle = e == 0 ? r.wheel_angle_rad : r.ref_angle_rad;
    const std::vector<double> rate = angle_rate(r.t_s, angle);
    std::vector<double>& d = e == 0 ? r.wheel_accel_mps2 : r.ref_decel_mps2;
    const double sign = e == 0 ? 1.0 : -1.0;  // d is +d v_wheel / dt, -d v_ref / dt
    for (std::size_t i = 0; i < n; ++i) {
      const double c = std::cos(angle[i]), s = std::sin(angle[i]);
      const double eps = fit.c[e] * c + fit.s[e] * s;
      const double eps_rate = (-fit.c[e] * s + fit.s[e] * c) * rate[i];
      const double v_mps = e == 0 ? r.v_ref_mps[i] * (1 - r.slip[i]) : r.v_ref_mps[i];
      if (i < d.size()) d[i] = d[i] * (1 - eps) - sign * v_mps * eps_rate;
    }
  }
  // s_measured = s - (1 - s) eps_wheel + (1 - s) eps_ref: the ripple is added back.
  for (std::size_t i = 0; i < n; ++i)
    r.slip[i] += ripple_fix(fit, r.slip[i], r.wheel_angle_rad[i], r.ref_angle_rad[i]);
}

}  // namespace

void take_out_ripple(Run& r, const SpeedRipple& ripple, ProbeAfter probe_after) {
  remove_ripple(r, ripple);
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
