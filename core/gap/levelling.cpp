// Levelling: the runs' slip biases from a constant quantised reference (a roller held at one
// speed, read in steps) are taken from their intercepts at zero force; a time offset levels at
// its own lag (Run::ref_bias_per_lag), a relaxation at its own length (Run::ref_bias_by_sigma).
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "core/gap/internal.hpp"

namespace brakefit::gap {

namespace {

/// Each run's intercept at zero force less the runs' mean: a line of common slope with an
/// intercept per run through the linear region (5-30 % of the largest force), the slip taken
/// lag_s earlier than the force (and the declared filter's tau: a filtered force channel shows
/// the linear region's force of tau earlier, else each ramp rate would level to its own lag),
/// or relaxed over sigma_m (the contact's slip, which trails the encoders' by about sigma / V
/// once the ramp has run that long, less on the run's first metres). Empty when a run has too
/// little of the linear region.
std::vector<double> intercept_offsets(const std::vector<Run>& runs, double lag_s,
                                      double* mean_out = nullptr, double sigma_m = 0) {
  double peak = 0;
  for (const Run& r : runs)
    for (double f : r.force_n) peak = std::max(peak, f);
  std::vector<double> mf(runs.size()), ms(runs.size());
  std::vector<std::vector<double>> slips;
  for (const Run& r : runs) {
    std::vector<double> base = r.slip;
    if (sigma_m > 0 && !base.empty()) base = relax(r, base, sigma_m, base.front());
    std::vector<double> s = base;
    if (const double back = r.pressure_filter_s + lag_s; back != 0)
      for (std::size_t i = 0; i < s.size(); ++i)
        s[i] = interp(r.t_s, base, std::max(r.t_s.front(), r.t_s[i] - back));
    slips.push_back(std::move(s));
  }
  double sff = 0, sfs = 0;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    const Run& r = runs[k];
    const std::vector<double>& slip = slips[k];
    double n = 0;
    for (std::size_t i = 0; i < r.slip.size(); ++i)
      if (r.force_n[i] >= 0.05 * peak && r.force_n[i] <= 0.3 * peak) {
        mf[k] += r.force_n[i];
        ms[k] += slip[i];
        ++n;
      }
    if (n < 5) return {};
    mf[k] /= n;
    ms[k] /= n;
    for (std::size_t i = 0; i < r.slip.size(); ++i)
      if (r.force_n[i] >= 0.05 * peak && r.force_n[i] <= 0.3 * peak) {
        sff += (r.force_n[i] - mf[k]) * (r.force_n[i] - mf[k]);
        sfs += (r.force_n[i] - mf[k]) * (slip[i] - ms[k]);
      }
  }
  if (!(sff > 0)) return {};
  const double slope = sfs / sff;  // slip per newton
  std::vector<double> icpt(runs.size());
  double mean = 0;
  for (std::size_t k = 0; k < runs.size(); ++k) mean += icpt[k] = ms[k] - slope * mf[k];
  mean /= static_cast<double>(runs.size());
  for (double& x : icpt) x -= mean;
  if (mean_out) *mean_out = mean;
  return icpt;
}

/// A wheel held on one quantised level at the run's start (Run::held_until_s) rolls free at the
/// tyre's zero-force slip, the same in every run: each run's level (in the levelled slip) bounds
/// it, and the runs' levels overlap where it is (their grids fall differently: three runs narrow
/// a step to about a quarter). The rebuilt channel read each rest at its level's edge, the first
/// crossings' line followed back (the wheel read as slowing 0.1-0.2 s early, a dead zone 15 %
/// short on generator B's roller); the level's middle is off by up to half a step in each run
/// (tried: B's nulls took the kink it left for a lag). The rest is put in the overlap, at its
/// point nearest the runs' zero-force intercept (intercept_ratio: a line through 5-30 % of the
/// peak, which the curve's bend puts a little below the foot, and a dead zone further; the
/// overlap's middle made B's null sets take the kinks for thresholds, largest null gain 0.078 ->
/// 0.110); the slip there becomes the larger of the rebuilt one and that rest (the wheel slows
/// from its rest, not before). Once, on the first levelling: the encoders' ripple estimates start
/// from the slip so placed.
void hold_rest_at_foot(std::vector<Run>& runs, double intercept_ratio) {
  auto bounds = [](const Run& r, std::size_t i) {
    return std::pair{
        1 - (r.held_level_mps + 0.5 * r.held_step_mps) / r.v_ref_mps[i] - r.ref_bias_removed,
        1 - (r.held_level_mps - 0.5 * r.held_step_mps) / r.v_ref_mps[i] - r.ref_bias_removed};
  };
  auto held = [](const Run& r) {
    return !r.held_placed && std::isfinite(r.held_until_s) && r.held_step_mps > 0 &&
           !r.slip.empty() && r.t_s.front() < r.held_until_s;
  };
  double lo = -INFINITY, hi = INFINITY;
  int count = 0;
  for (const Run& r : runs)
    if (held(r)) {
      const auto [l, h] = bounds(r, 0);
      lo = std::max(lo, l);
      hi = std::min(hi, h);
      ++count;
    }
  if (count < 2 || lo > hi) return;
  const double foot_ratio = std::clamp(intercept_ratio, lo, hi);
  for (Run& r : runs) {
    if (!held(r)) continue;
    r.held_placed = true;
    for (std::size_t i = 0; i < r.slip.size() && r.t_s[i] < r.held_until_s; ++i) {
      const auto [l, h] = bounds(r, i);
      r.slip[i] = std::max(r.slip[i], std::clamp(foot_ratio, l, h));
    }
  }
}

/// The lag at which the levelling's sensitivity to a time offset is measured.
constexpr double kLevellingLagProbeS = 0.01;

}  // namespace

double relaxation_level_change(const Run& r, double sigma_m) {
  if (r.ref_bias_by_sigma.size() != kLevellingSigmaM.size() || !(sigma_m > 0)) return 0.0;
  const auto hi = std::upper_bound(kLevellingSigmaM.begin(), kLevellingSigmaM.end(), sigma_m);
  if (hi == kLevellingSigmaM.end()) return r.ref_bias_by_sigma.back();
  const auto i = static_cast<std::size_t>(hi - kLevellingSigmaM.begin());
  const double w =
      (sigma_m - kLevellingSigmaM[i - 1]) / (kLevellingSigmaM[i] - kLevellingSigmaM[i - 1]);
  return (1 - w) * r.ref_bias_by_sigma[i - 1] + w * r.ref_bias_by_sigma[i];
}

std::string level_reference_biases(std::vector<Run>& runs) {
  // The slip at zero force is the same in every run (a slip offset is the runs' common effect):
  // each run's intercept less the mean intercept, within its bound, is its reference bias.
  std::size_t biased = 0;
  for (const Run& r : runs) biased += r.ref_bias_bound > 0;
  if (biased == 0 || runs.size() < 2) return {};
  double mean_icpt = 0;
  const std::vector<double> offset = intercept_offsets(runs, 0.0, &mean_icpt);
  if (offset.empty()) return {};
  // A time offset moves each run's intercept by its slip rate times the lag: levelled at zero
  // lag, the biases would take the lag's signature in the linear region (a 12 ms lag on
  // generator B's roller was fitted as 3-6 ms). A time offset levels at its own lag: the
  // biases' change per second of lag is kept (ref_bias_per_lag, see predict).
  const std::vector<double> lagged = intercept_offsets(runs, kLevellingLagProbeS);
  // A relaxation's lag, sigma / V, is 0.1-0.3 s on a roller, ten to thirty times the probe, and
  // builds up over the run's first metres: no line carries it there, and levelled at none the
  // biases take part of the lag's signature (the relaxation reads short). The change is read at
  // each length of a grid instead.
  std::vector<std::vector<double>> relaxed;
  relaxed.reserve(kLevellingSigmaM.size());
  for (double sigma_m : kLevellingSigmaM)
    relaxed.push_back(sigma_m > 0 ? intercept_offsets(runs, 0.0, nullptr, sigma_m) : offset);
  double largest = 0;
  for (std::size_t k = 0; k < runs.size(); ++k) {
    Run& r = runs[k];
    if (r.ref_bias_bound <= 0) continue;
    // Levelled again after the ripple is out: the total stays within the bound.
    r.ref_bias_wanted = r.ref_bias_removed + offset[k];
    const double total = std::clamp(r.ref_bias_wanted, -r.ref_bias_bound, r.ref_bias_bound);
    for (double& x : r.slip) x -= total - r.ref_bias_removed;
    r.ref_bias_removed = total;
    r.ref_bias_per_lag = lagged.empty() ? 0.0 : (lagged[k] - offset[k]) / kLevellingLagProbeS;
    r.ref_bias_by_sigma.clear();
    for (const auto& o : relaxed) r.ref_bias_by_sigma.push_back(o.empty() ? 0.0 : o[k] - offset[k]);
    largest = std::max(largest, std::abs(total));
  }
  hold_rest_at_foot(runs, mean_icpt);
  return fmt::format(
      "the reference speed was constant and quantised (a roller read at {:.2g} m/s resolution): "
      "each run's slip is off by up to half a step of it ({:.2g}); the runs' slips were levelled "
      "at zero force (largest correction {:.2g})",
      runs.front().v_ref_step_mps, runs.front().ref_bias_bound, largest);
}

}  // namespace brakefit::gap
