// What the baseline leaves: the noise floor it is judged against (the force channel's noise and
// the slip noise through the curve's slope), where its residual sits, and a neutral start that its
// distortion cannot trap.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"

namespace brakefit::gap {

namespace {

/// The fewest steps between samples at rest that measure a run's speed noise, or, over all runs,
/// the set's, where no run is long enough to measure it on its slip.
constexpr std::size_t kPooledNoisePoints = 10;

double mean_speed_mps(const Run& r) {
  double v = 0;
  for (double x : r.v_ref_mps) v += x / static_cast<double>(r.v_ref_mps.size());
  return v;
}

}  // namespace

Floor noise_floor(const std::vector<Run>& runs, const std::vector<double>& params) {
  const MfParams m = curve_of(params);
  Floor fl;
  // The slip's noise is measured on the run's own slip (4 wide windows: 130 samples at 1 kHz).
  // Shorter runs (a 60 bar/s roller stop of generator B's relaxing tyre lasts 50 ms, a ground
  // run at 500 Hz 0.2 s) were counted noise-free: their floor was the force's alone. They take
  // the measured runs' speed noise (slip noise times speed: the instruments', the same in every
  // run of a set) at their own speed, as the measured runs have it now (with the encoders'
  // ripple out, when it was taken out since).
  int measured = 0;
  double speed_noise_mps = 0;
  for (const Run& r : runs)
    if (!r.slip_sd_unmeasured && !r.slip_sd.empty() && !r.v_ref_mps.empty()) {
      speed_noise_mps += r.slip_sd.front() * mean_speed_mps(r);
      ++measured;
    }
  if (measured > 0) speed_noise_mps /= measured;
  // No run long enough (a 50 Hz export of 0.3 s stops: 12-17 samples each): the floor would be
  // the force channel's alone (2 N for a car at 31-120 km/h whose speeds carry 2-11 mm/s of
  // noise, 13 N through the curve's slope), and a fitted model's 14 N called a structure no
  // effect explains. Each run's slip at rest measures its speed noise; runs with little rest take
  // the set's, pooled over all steps at rest.
  if (measured == 0) {
    double sq = 0;
    std::size_t points = 0;
    for (const Run& r : runs)
      if (std::isfinite(r.rest_noise_mps)) {
        sq += static_cast<double>(r.rest_slip_steps) * r.rest_noise_mps * r.rest_noise_mps;
        points += r.rest_slip_steps;
      }
    if (points >= kPooledNoisePoints) {
      speed_noise_mps = std::sqrt(sq / static_cast<double>(points));
      fl.pooled_noise = true;
    }
  }
  // RMS over runs of each run's mean square, as the held-out gap weighs its runs.
  double force_sq = 0, slip_sq = 0, sd_sq = 0;
  for (const Run& r : runs) {
    force_sq += r.noise_n * r.noise_n;
    fl.v_ref_sd_mps += r.v_ref_sd_mps * r.v_ref_sd_mps;
    fl.v_wheel_sd_mps += r.v_wheel_sd_mps * r.v_wheel_sd_mps;
    fl.v_ref_step_mps = std::max(fl.v_ref_step_mps, r.v_ref_step_mps);
    fl.v_wheel_step_mps = std::max(fl.v_wheel_step_mps, r.v_wheel_step_mps);
    fl.force_step_n = std::max(fl.force_step_n, r.force_step_n);
    double run_slip_sq = 0, run_sd_sq = 0;
    const std::size_t points = std::min(r.slip.size(), r.slip_sd.size());
    const bool borrows =
        r.slip_sd_unmeasured && (measured > 0 || fl.pooled_noise) && !r.v_ref_mps.empty();
    // A run's own rest, where it has enough of it (the noise of an export's speeds can grow with
    // the speed: 3 to 11 mm/s from 31 to 120 km/h in one of generator B's sets).
    const bool own_rest =
        measured == 0 && r.rest_slip_steps >= kPooledNoisePoints && std::isfinite(r.rest_noise_mps);
    const double borrowed_sd =
        borrows ? (own_rest ? r.rest_noise_mps : speed_noise_mps) / std::max(mean_speed_mps(r), 0.1)
                : 0.0;
    if (borrows) {
      ++fl.borrowed_runs;
      fl.borrowed_speed_noise_mps = speed_noise_mps;
    }
    for (std::size_t i = 0; i < points; ++i) {
      const double h = 1e-5;  // dF/dslip of the curve at the point
      const double slope = (mf_force_n(m, r.slip[i] + h) - mf_force_n(m, r.slip[i] - h)) / (2 * h);
      const double point_sd_sq = r.slip_sd[i] * r.slip_sd[i] + borrowed_sd * borrowed_sd;
      run_slip_sq += slope * slope * point_sd_sq;
      run_sd_sq += point_sd_sq;
    }
    if (points == 0) continue;
    slip_sq += run_slip_sq / static_cast<double>(points);
    sd_sq += run_sd_sq / static_cast<double>(points);
  }
  const auto n = static_cast<double>(runs.size());
  fl.force_n = std::sqrt(force_sq / n);
  fl.v_ref_sd_mps = std::sqrt(fl.v_ref_sd_mps / n);
  fl.v_wheel_sd_mps = std::sqrt(fl.v_wheel_sd_mps / n);
  fl.slip_n = std::sqrt(slip_sq / n);
  fl.slip_sd_ratio = std::sqrt(sd_sq / n);
  return fl;
}

std::string borrowed_noise_note(const Floor& fl) {
  if (fl.borrowed_runs == 0) return {};
  if (fl.pooled_noise)
    return fmt::format(
        "the runs are each too short to measure their slip noise on (under 4 smoothing windows): "
        "their slip at rest before the brake measures it ({} runs, {:.2g} m/s of speed over "
        "them)",
        fl.borrowed_runs, fl.borrowed_speed_noise_mps);
  return fmt::format(
      "{} run(s) too short to measure their slip noise on (under 4 smoothing windows) took the "
      "other runs' speed noise, {:.2g} m/s, at their own speed",
      fl.borrowed_runs, fl.borrowed_speed_noise_mps);
}

/// Where: residual of the 4-parameter model by slip region, by phase, by run.
std::vector<WhereRow> where_rows(const std::vector<Run>& runs, const std::vector<double>& params,
                                 const std::vector<Effect>& baseline) {
  const MfParams base = curve_of(params);
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
    const auto f = predict(r, params, baseline);
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

}  // namespace brakefit::gap
