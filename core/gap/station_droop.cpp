// A roller drive droops alike in every run of a station: the runs that show it fitted again
// together (one droop per newton behind one lag, a short run's few transitions cannot tell its
// droop from its lag), a run read as held that takes it, and the misfit at each lag the drive's
// transitions allow (droop_lag.cpp asks a time offset or relaxation to beat them).
#include <fmt/format.h>
#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "core/gap/droop_fit.hpp"
#include "core/gap/internal.hpp"

namespace brakefit::gap {

namespace {

using droop::DroopFit;
using droop::kDroopLags;
using droop::kMaxMissSteps;
using droop::lagged_load;
using droop::largest_force_n;
using droop::Stair;

/// A run read as held takes a station's droop only where it droops by at most this many steps
/// over the run (more, and its staircase would have shown it).
constexpr double kMaxSharedDroopSteps = 1.0;

/// A roller run whose own staircase drooped (its droop fitted, its staircase kept).
bool droops(const Run& r) {
  return r.bench == can::BenchKind::Roller && r.roller_droop_mps_per_n > 0 && r.roller_staircase;
}

/// The fitted runs' staircases, with their slow trends or without (joint_stairs).
struct JointStairs {
  std::vector<Stair> stairs;
  DroopFit fit;
};

/// The runs' staircases fitted together (at fixed_tau_s where given). Without the runs' slow
/// trends first: over a pedal ramp the force rises about linearly in time, and a run's trend
/// takes the droop's place (a heavy station's runs read 0.76-1.09 mm/s per kN with their trends,
/// 1.35 together without them, the drive's 1.35). The trends come back only where the runs'
/// transitions cannot be met without them.
JointStairs joint_stairs(const std::vector<const Run*>& fitted, std::optional<double> fixed_tau_s) {
  JointStairs out;
  out.stairs.reserve(fitted.size());
  for (const Run* r : fitted)
    out.stairs.push_back(droop::read_stair(droop::view_of(*r->roller_staircase)));
  std::vector<Stair> plain = out.stairs;
  for (Stair& st : plain) st.trend = false;
  out.fit = droop::fit_droop(plain, fixed_tau_s);
  if (out.fit.x.size() >= 2 && out.fit.miss_steps() <= kMaxMissSteps)
    out.stairs = std::move(plain);
  else
    out.fit = droop::fit_droop(out.stairs, fixed_tau_s);
  return out;
}

/// The runs whose droop was fitted, fitted again together: a short run's few transitions cannot
/// tell the droop from its lag (three runs of a station with 1-5 transitions each read no lag and
/// half the droop that a run of 11 read at 0.4 s). Each run's speed is rebuilt with the joint
/// droop and its slip recomputed; returns the joint droop (m/s per N, lag in s), or nothing where
/// the joint fit misses the transitions (the runs keep their own). At fixed_tau_s where given.
std::optional<std::pair<double, double>> refit_together(
    std::vector<Run*>& fitted, std::optional<double> fixed_tau_s = std::nullopt) {
  auto [stairs, fit] = joint_stairs({fitted.begin(), fitted.end()}, fixed_tau_s);
  if (fit.x.size() < 2 || !(fit.miss_steps() <= kMaxMissSteps) || !(fit.mps_per_kn() > 0))
    return std::nullopt;
  for (std::size_t j = 0; j < fitted.size(); ++j) {
    Run& r = *fitted[j];
    const Stair& st = stairs[j];
    const auto v_full = droop::rebuilt_speed(st, fit);
    // The run's samples are a subset of the staircase's (decimation keeps the times as they were).
    for (std::size_t i = 0; i < r.t_s.size(); ++i) {
      const auto at = std::lower_bound(st.s.t_s.begin(), st.s.t_s.end(), r.t_s[i]);
      if (at == st.s.t_s.end() || *at != r.t_s[i]) continue;
      const double v_new = v_full[static_cast<std::size_t>(at - st.s.t_s.begin())];
      if (!(v_new > 0)) continue;
      r.slip[i] = 1 - (1 - r.slip[i]) * r.v_ref_mps[i] / v_new;
      r.v_ref_mps[i] = v_new;
    }
    r.roller_droop_mps_per_n = fit.mps_per_kn() * 1e-3;
    r.roller_droop_lag_s = fit.tau_s;
  }
  return std::pair{fit.mps_per_kn() * 1e-3, fit.tau_s};
}

}  // namespace

std::string share_roller_droop(std::vector<Run>& runs) {
  std::vector<Run*> fitted;
  for (Run& r : runs)
    if (droops(r)) fitted.push_back(&r);
  if (fitted.empty()) return {};
  // In the order of their own droops (the joint fit's columns, and the median where it misses).
  std::sort(fitted.begin(), fitted.end(), [](const Run* a, const Run* b) {
    return a->roller_droop_mps_per_n < b->roller_droop_mps_per_n;
  });
  const auto together = fitted.size() > 1 ? refit_together(fitted) : std::nullopt;
  // One run, or a joint fit that misses: the median of the runs' own.
  const Run& median = *fitted[fitted.size() / 2];
  const auto [k, tau_s] =
      together.value_or(std::pair{median.roller_droop_mps_per_n, median.roller_droop_lag_s});
  std::size_t changed = 0, refused = 0;
  double largest_mps = 0;
  for (Run& r : runs) {
    if (r.bench != can::BenchKind::Roller || !r.roller_held_quantised || r.t_s.size() < 2) continue;
    const double f_max = largest_force_n(r.force_n);
    const auto load = lagged_load(r.t_s, r.force_n, tau_s);
    double mean = 0;
    for (double x : load) mean += x / static_cast<double>(load.size());
    // The run's staircase did not droop by half a step (it was read as held): a droop of more
    // than a step over it is not this run's (a droop fitted on one run through a lagging
    // channel read 1.7 mm/s per kN, 6 steps over another run that held its level).
    const auto [lo, hi] = std::minmax_element(load.begin(), load.end());
    if (!(k * f_max * (*hi - *lo) <= kMaxSharedDroopSteps * r.v_ref_step_mps)) {
      ++refused;
      continue;
    }
    for (std::size_t i = 0; i < r.t_s.size(); ++i) {
      const double dv = -k * f_max * (load[i] - mean);
      const double v_new = r.v_ref_mps[i] + dv;
      if (!(v_new > 0)) continue;
      r.slip[i] = 1 - (1 - r.slip[i]) * r.v_ref_mps[i] / v_new;
      r.v_ref_mps[i] = v_new;
      largest_mps = std::max(largest_mps, std::abs(dv));
    }
    r.roller_held_quantised = false;
    ++changed;
  }
  if (changed == 0 && !together) return {};
  const std::string source =
      together ? fmt::format(
                     "fitted to the transitions of the {} runs whose quantised speed stepped "
                     "with it together",
                     fitted.size())
               : fmt::format("the median of {} run(s) whose quantised speed stepped with it",
                             fitted.size());
  std::string note = fmt::format(
      "the roller's drive droops under the brake's force ({:.3g} mm/s per kN behind a {:.2f} s "
      "lag, {})",
      1e6 * k, tau_s, source);
  if (changed > 0)
    note += fmt::format(
        ": {} run(s) whose droop stayed within a step of the channel, read as held, took it (at "
        "most {:.2f} mm/s)",
        changed, 1e3 * largest_mps);
  if (refused > 0)
    note += fmt::format(
        "; {} held run(s) would have drooped by more than a step and did not take it", refused);
  return note;
}

DroopLagProfile droop_lag_profile(const std::vector<Run>& runs) {
  std::vector<const Run*> fitted;
  for (const Run& r : runs)
    if (droops(r)) fitted.push_back(&r);
  if (fitted.empty()) return {};
  DroopLagProfile out;
  out.read_s = fitted.front()->roller_droop_lag_s;
  JointStairs js = joint_stairs(fitted, out.read_s);
  if (js.fit.x.size() < 2) return {};
  out.dof = std::max<double>(1.0, static_cast<double>(js.fit.rows - js.fit.cols));
  out.lag_rss.emplace_back(out.read_s, js.fit.rss_steps2);
  const auto steps = static_cast<int>(std::lround(kDroopLags.back() / out.step_s));
  for (int k = 0; k <= steps; ++k) {
    const double tau_s = k * out.step_s;
    const DroopFit f = droop::fit_droop(js.stairs, tau_s);
    if (f.x.size() >= 2 && f.mps_per_kn() > 0 && std::isfinite(f.rss_steps2))
      out.lag_rss.emplace_back(tau_s, f.rss_steps2);
  }
  return out;
}

bool refit_droop_at(std::vector<Run>& runs, double tau_s) {
  std::vector<Run*> fitted;
  for (Run& r : runs)
    if (droops(r)) fitted.push_back(&r);
  return !fitted.empty() && refit_together(fitted, tau_s).has_value();
}

}  // namespace brakefit::gap
