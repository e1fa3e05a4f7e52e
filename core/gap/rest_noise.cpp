// A run too short to measure its slip noise on (Run::slip_sd_unmeasured) measures it on its slip
// at rest before the brake, where the signal is flat: the speeds' noise per sample, through the
// smoother's gain. An encoder's once-per-revolution ripple is not noise: a ripple taken out of
// the run is taken out of its rest the same way (at 50 Hz a wheel at 130 km/h turns 20 times a
// second and its ripple reads as a noise ten times the speeds'). The same rests check a ripple's
// amplitude read on the runs' residual, which on short runs can hold an effect's bend, and read
// it, with its phase, where no run turns the encoder often enough to.
#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <optional>

#include "core/gap/internal.hpp"

namespace brakefit::gap {

namespace {
/// A rest fitted for what is left of a ripple keeps at least this many samples beyond its
/// columns.
constexpr Eigen::Index kRestFitSpareSamples = 6;

/// A probe's samples at rest, and the columns a ripple is fitted with there: a level and each
/// chosen encoder's (1 - s) cos and sin of its angle.
struct RestFit {
  std::vector<std::size_t> at;
  Eigen::MatrixXd a;
  Eigen::VectorXd b;  ///< the slip
};
RestFit rest_fit(const Run::RestProbe& p, std::array<bool, 2> encoders) {
  RestFit f;
  for (std::size_t i = 0; i < p.slip.size(); ++i)
    if (std::isfinite(p.slip[i])) f.at.push_back(i);
  const auto rows = static_cast<Eigen::Index>(f.at.size());
  f.a.resize(rows, 1 + 2 * (encoders[0] + encoders[1]));
  f.b.resize(rows);
  for (Eigen::Index j = 0; j < rows; ++j) {
    const std::size_t i = f.at[static_cast<std::size_t>(j)];
    Eigen::Index col = 0;
    f.a(j, col++) = 1.0;
    for (std::size_t e = 0; e < 2; ++e) {
      if (!encoders[e]) continue;
      const double ang = e == 0 ? p.wheel_angle_rad[i] : p.ref_angle_rad[i];
      f.a(j, col++) = (1 - p.slip[i]) * std::cos(ang);
      f.a(j, col++) = (1 - p.slip[i]) * std::sin(ang);
    }
    f.b(j) = p.slip[i];
  }
  return f;
}
}  // namespace

Run::RestProbe rest_probe(std::span<const pipeline::Sample> rest, double rest_bar,
                          const RestGeometry& g) {
  Run::RestProbe p;
  const std::size_t n = rest.size();
  p.slip.assign(n, NAN);
  p.wheel_angle_rad.assign(n, 0.0);
  p.ref_angle_rad.assign(n, 0.0);
  double v_rest_mps = 0;
  int points = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const pipeline::Sample& s = rest[i];
    if (at_rest(s, rest_bar)) {
      p.slip[i] = 1.0 - s.v_wheel_mps / s.v_ref_mps;
      v_rest_mps += s.v_ref_mps;
      ++points;
    }
  }
  if (points > 0)
    p.step_sd_ratio =
        std::hypot(g.v_wheel_step_mps, g.v_ref_step_mps) / std::sqrt(12.0) / (v_rest_mps / points);
  // Rolled back from the last sample at rest (the run's first, where its angles start at 0) on
  // the sampler's clock, as the run's angles are: at 50 Hz a stamp's 1-5 ms of jitter is 0.1-0.6
  // rad of a wheel at 130 km/h. A speed that is not a number takes its neighbour's.
  auto mean = [](double a, double b) {
    if (!std::isfinite(a)) return std::isfinite(b) ? b : 0.0;
    return std::isfinite(b) ? 0.5 * (a + b) : a;
  };
  for (std::size_t i = n; i-- > 1;) {
    const double stamps_s = static_cast<double>(rest[i].t_ns - rest[i - 1].t_ns) * 1e-9;
    const double dt_s = g.interval_s > 0
                            ? std::max(1.0, std::round(stamps_s / g.interval_s)) * g.interval_s
                            : stamps_s;
    p.wheel_angle_rad[i - 1] =
        p.wheel_angle_rad[i] -
        mean(rest[i].v_wheel_mps, rest[i - 1].v_wheel_mps) * dt_s / g.wheel_radius_m;
    p.ref_angle_rad[i - 1] =
        p.ref_angle_rad[i] - mean(rest[i].v_ref_mps, rest[i - 1].v_ref_mps) * dt_s / g.ref_radius_m;
  }
  // A frame mean describes the moment half a frame before its stamp (the run's speeds were moved
  // forward by as much before their angles were rolled).
  if (g.frame_shift_s > 0)
    for (std::size_t i = 0; i < n; ++i) {
      if (std::isfinite(rest[i].v_wheel_mps))
        p.wheel_angle_rad[i] -= g.frame_shift_s * rest[i].v_wheel_mps / g.wheel_radius_m;
      if (std::isfinite(rest[i].v_ref_mps))
        p.ref_angle_rad[i] -= g.frame_shift_s * rest[i].v_ref_mps / g.ref_radius_m;
    }
  return p;
}

Run::RestProbe rest_probe_without(const Run::RestProbe& p, const SpeedRipple& ripple) {
  Run::RestProbe out = p;
  for (std::size_t i = 0; i < out.slip.size(); ++i)
    if (std::isfinite(p.slip[i]))
      out.slip[i] += ripple_slip_fix(ripple, p.slip[i], p.wheel_angle_rad[i], p.ref_angle_rad[i]);
  return out;
}

void measure_rest_noise(Run& r, const SpeedRipple& ripple) {
  r.rest_noise_mps = NAN;
  r.rest_slip_steps = 0;
  if (!r.rest_probe) return;
  Run::RestProbe p = rest_probe_without(*r.rest_probe, ripple);
  // What the run's estimate left of its ripple is fitted on the rest itself (a level and each
  // used encoder's cos and sin): the run's phase, read through the smoother on a wheel near the
  // sampler's Nyquist rate, can miss the rest's by a radian, and a 3e-4 ripple left at a third of
  // its size is still twice the speeds' noise.
  double dof_scale = 1.0;
  if (ripple.used[0] || ripple.used[1]) {
    const RestFit f = rest_fit(p, ripple.used);
    const Eigen::Index rows = f.a.rows(), cols = f.a.cols();
    if (rows >= cols + kRestFitSpareSamples) {
      const Eigen::VectorXd resid = f.b - f.a * f.a.colPivHouseholderQr().solve(f.b);
      for (Eigen::Index j = 0; j < rows; ++j) p.slip[f.at[static_cast<std::size_t>(j)]] = resid(j);
      dof_scale = std::sqrt(static_cast<double>(rows) / static_cast<double>(rows - cols));
    }
  }
  std::vector<double> steps;  // from one sample at rest to the next
  for (std::size_t i = 1; i < p.slip.size(); ++i)
    if (std::isfinite(p.slip[i]) && std::isfinite(p.slip[i - 1]))
      steps.push_back(std::abs(p.slip[i] - p.slip[i - 1]));
  r.rest_slip_steps = steps.size();
  if (steps.size() < 2) return;
  // Robustly (the median step as a white noise's): the wheel that starts to slow behind a
  // lagging pressure channel in the last samples at rest would dominate a variance.
  // A quantised channel dithered by the ripple or the noise reads as a staircase's error, which
  // the run counts where it rebuilds its staircase (slip_sd): it is the noise beyond it.
  const double sd_ratio = upper_median(steps) / 0.6745 / std::sqrt(2.0) * dof_scale;
  r.rest_noise_mps =
      std::sqrt(std::max(sd_ratio * sd_ratio - p.step_sd_ratio * p.step_sd_ratio, 0.0)) *
      p.gain_mps;
}

namespace {

struct RestOwn {
  double amplitude = 0.0, se = 0.0;
  double c = 0.0, s = 0.0;  ///< the slip's coefficients on (1 - s) cos and sin of the angle
};
/// A rest's own ripple of one encoder and its standard error; nullopt where the rest cannot
/// resolve one (too few samples, under a fraction of a revolution). Checked against a ripple
/// read on the runs, the rest fits a level and that encoder's cos and sin. Read alone
/// (`alone`), it fits both encoders' (the other's ripple is in the rest's slip too) and leaves
/// out the samples more than kRestOutlierSds robust deviations off that fit, refitted: the
/// rest's last samples can hold the wheel starting to slow behind a lagging pressure channel (a
/// 12 ms filter: 0.011 of slip against a 4e-4 ripple, which then read as noise 3x its size).
std::optional<RestOwn> rest_own_ripple(const Run::RestProbe& probe, std::size_t encoder,
                                       bool alone = false) {
  constexpr double kRestOutlierSds = 5.0;
  RestFit f = rest_fit(probe, {encoder == 0 || alone, encoder == 1 || alone});
  const Eigen::Index c = alone && encoder == 1 ? 3 : 1;  // the encoder's cos column
  for (int pass = 0;; ++pass) {
    const Eigen::MatrixXd& a = f.a;
    if (a.rows() < a.cols() + kRestFitSpareSamples) return std::nullopt;
    const Eigen::MatrixXd ata = a.transpose() * a;
    const Eigen::FullPivLU<Eigen::MatrixXd> lu(ata);
    if (!lu.isInvertible()) return std::nullopt;
    const Eigen::VectorXd x = lu.solve(a.transpose() * f.b);
    const Eigen::VectorXd resid = f.b - a * x;
    std::vector<double> dev(resid.data(), resid.data() + resid.size());
    for (double& d : dev) d = std::abs(d);
    const double limit = kRestOutlierSds * 1.4826 * upper_median(dev);  // 1.4826 MAD: a normal sd
    std::vector<Eigen::Index> keep;
    for (Eigen::Index j = 0; j < resid.size(); ++j)
      if (std::abs(resid(j)) <= limit) keep.push_back(j);
    if (!alone || pass > 0 || !(limit > 0) ||
        keep.size() == static_cast<std::size_t>(resid.size())) {
      const double var = resid.squaredNorm() / static_cast<double>(a.rows() - a.cols());
      const Eigen::MatrixXd cov = var * lu.inverse();
      return RestOwn{std::hypot(x(c), x(c + 1)), std::sqrt(0.5 * (cov(c, c) + cov(c + 1, c + 1))),
                     x(c), x(c + 1)};
    }
    f.a = a(keep, Eigen::all).eval();
    f.b = f.b(keep).eval();
  }
}

constexpr double kRestSigmas = 3.0;

}  // namespace

RestRippleCheck rest_ripple_check(const std::vector<Run>& runs, std::size_t encoder,
                                  double amplitude) {
  RestRippleCheck out;
  std::vector<double> owns;  // each judging rest's own amplitude
  for (const Run& r : runs) {
    if (!r.rest_probe) continue;
    const auto own = rest_own_ripple(*r.rest_probe, encoder);
    if (!own || !(kRestSigmas * own->se < amplitude)) continue;  // this rest could not see it
    owns.push_back(own->amplitude);
    out.largest_rest_amplitude = std::max(out.largest_rest_amplitude, own->amplitude);
    if (amplitude - own->amplitude > kRestSigmas * own->se) ++out.refuted;
  }
  out.judged = static_cast<int>(owns.size());
  if (!owns.empty()) out.rest_amplitude = upper_median(owns);
  return out;
}

RestRipple rest_ripple(const std::vector<Run>& runs, std::size_t encoder) {
  RestRipple out;
  out.phase.resize(runs.size());
  std::vector<std::optional<RestOwn>> own(runs.size());
  std::vector<double> owns;
  int seen = 0;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    if (runs[k].rest_probe) own[k] = rest_own_ripple(*runs[k].rest_probe, encoder, true);
    if (!own[k]) continue;
    owns.push_back(own[k]->amplitude);
    if (own[k]->amplitude > kRestSigmas * own[k]->se) ++seen;
  }
  if (!(2 * seen > static_cast<int>(owns.size()))) return out;
  out.amplitude = upper_median(owns);
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const auto& o = own[k];
    if (!o || !(o->amplitude > kRestSigmas * o->se) || o->amplitude < 0.5 * out.amplitude ||
        o->amplitude > 2 * out.amplitude)
      continue;
    // A speed read as v (1 + eps) puts -(1 - s) eps_wheel and +(1 - s) eps_ref into the slip.
    const double scale = (encoder == 0 ? -1.0 : 1.0) * out.amplitude / o->amplitude;
    out.phase[k] = std::array<double, 2>{scale * o->c, scale * o->s};
  }
  return out;
}

}  // namespace brakefit::gap
