// A roller whose drive slows under the brake's load (the motor's slip; a few % with a heavy
// vehicle), read through a quantised channel: its speed rebuilt as a level, a droop following the
// brake's force behind a lag, a slow trend and the encoder's ripple, fitted to where the staircase
// steps (there the speed crossed the middle of the two levels). A fit to the staircase itself is
// unbiased only where a ripple of a step or more dithers the levels; a droop of two or three steps
// over a short run leaves a few transitions and long stretches on one level, where the
// staircase's least squares put the speed half a step off (a slip error of 5e-4 at 1.1 m/s).
#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <vector>

#include "core/gap/droop_fit.hpp"
#include "core/gap/internal.hpp"

namespace brakefit::gap {

namespace droop {

namespace {

/// Golden-section steps refining the lag between the grid's points (0.4 s to 1 ms in 12).
constexpr int kDroopLagRefinements = 12;
/// Transitions needed for the slow trend's two columns, and for the ripple's four.
constexpr std::size_t kTrendTransitions = 20, kRippleTransitions = 16;
/// Transitions per turn of the roller the ripple's columns need (two a cycle): they are read only
/// where the staircase steps, and a long slow run steps about once a turn. There a ripple fitted
/// from 25 transitions over 24 turns read 2.5 mm/s for the drive's 0.35 mm/s, and the run's
/// level, pinned at its rest by that phantom, 1.3 mm/s high (a slip error of 1e-3: 130 N across a
/// car's linear region).
constexpr double kRippleTransitionsPerTurn = 2.0;

/// The lagged force in kN (the droop's column: one drive loses the same speed per newton in every
/// run of a station).
std::vector<double> lagged_force_kn(const std::vector<double>& t_s, const std::vector<double>& f,
                                    double tau_s) {
  auto y = lagged_load(t_s, f, tau_s);
  const double scale_kn = largest_force_n(f) * 1e-3;
  for (double& x : y) x *= scale_kn;
  return y;
}
}  // namespace

double largest_force_n(const std::vector<double>& f) {
  double f_max = 0;
  for (double x : f) f_max = std::max(f_max, std::abs(x));
  return f_max;
}

std::vector<double> lagged_load(const std::vector<double>& t_s, const std::vector<double>& f,
                                double tau_s) {
  const double f_max = largest_force_n(f);
  std::vector<double> y(f.size(), 0.0);
  if (f.empty() || f_max <= 0) return y;
  double s = f.front() / f_max;
  for (std::size_t i = 0; i < f.size(); ++i) {
    const double h = i ? t_s[i] - t_s[i - 1] : 0.0;
    s += tau_s > 0 ? (f[i] / f_max - s) * (1 - std::exp(-h / tau_s)) : f[i] / f_max - s;
    y[i] = s;
  }
  return y;
}

Stair read_stair(const StaircaseView& s) {
  Stair out{s, {}, 0, 1, false, 0, 0};
  const std::size_t n = s.t_s.size();
  for (std::size_t i = 1; i < n; ++i)
    if (s.v_mps[i] != s.v_mps[i - 1]) out.at.push_back(i);
  for (double x : s.v_mps) out.mean_mps += x / static_cast<double>(n);
  out.span_s = std::max(s.t_s.back() - s.t_s.front(), 1e-6);
  out.trend = out.at.size() >= kTrendTransitions;
  const double turns = out.mean_mps * out.span_s / (2 * M_PI * s.roller_radius_m);
  out.harmonics = out.at.size() >= kRippleTransitions && turns >= kHeldRollerMinTurns &&
                          static_cast<double>(out.at.size()) >= kRippleTransitionsPerTurn * turns
                      ? 2
                      : 0;
  return out;
}

DroopFit fit_droop(std::vector<Stair>& stairs, std::optional<double> fixed_tau_s) {
  Eigen::Index cols = 1, rows = 0;
  for (Stair& st : stairs) {
    st.first_col = cols;
    cols += st.count();
    // One row more a run: the roller before the brake (its first level, at the load there)
    // pins the level where a droop of a step or two crossed one boundary only.
    rows += static_cast<Eigen::Index>(st.at.size()) + 1;
  }
  DroopFit best;
  best.rows = rows;
  best.cols = cols;
  auto try_lag = [&](double tau_s) {
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(rows, cols);
    Eigen::VectorXd b(rows);
    Eigen::Index row = 0;
    for (const Stair& st : stairs) {
      const auto load = lagged_force_kn(st.s.t_s, st.s.force_n, tau_s);
      const double w = 1 / st.s.step_mps;
      for (const std::size_t i : st.at) {
        st.fill(a, row, 0.5 * (st.s.t_s[i] + st.s.t_s[i - 1]), 0.5 * (load[i] + load[i - 1]));
        b(row) = 0.5 * (st.s.v_mps[i] + st.s.v_mps[i - 1]);
        a.row(row) *= w;
        b(row++) *= w;
      }
      st.fill(a, row, st.s.t_s.front(), load.front());
      b(row) = st.s.v_mps.front();
      a.row(row) *= w;
      b(row++) *= w;
    }
    const Eigen::VectorXd x = a.colPivHouseholderQr().solve(b);
    const double rss = (a * x - b).squaredNorm();
    if (rss < best.rss_steps2) {
      best.rss_steps2 = rss;
      best.x = x;
      best.tau_s = tau_s;
    }
    return rss;
  };
  if (fixed_tau_s) {
    try_lag(*fixed_tau_s);
    return best;
  }
  for (double tau_s : kDroopLags) try_lag(tau_s);
  // The lag between the grid's neighbours of the best, by golden section: on a fast pedal ramp
  // the drive's speed falls at up to 20 mm/s^2, and a lag 50 ms off puts the rebuilt speed a
  // millimetre per second off (a slip error of 1e-3 at 4 km/h, more than a wheel's inertia leaves).
  const auto it = std::find(kDroopLags.begin(), kDroopLags.end(), best.tau_s);
  double lo = it == kDroopLags.begin() ? kDroopLags.front() : *(it - 1);
  double hi = it + 1 == kDroopLags.end() ? kDroopLags.back() : *(it + 1);
  constexpr double kGolden = 0.6180339887498949;
  double x1 = hi - kGolden * (hi - lo), x2 = lo + kGolden * (hi - lo);
  double f1 = try_lag(x1), f2 = try_lag(x2);
  for (int k = 0; k < kDroopLagRefinements; ++k) {
    if (f1 < f2) {
      hi = x2;
      x2 = x1;
      f2 = f1;
      x1 = hi - kGolden * (hi - lo);
      f1 = try_lag(x1);
    } else {
      lo = x1;
      x1 = x2;
      f1 = f2;
      x2 = lo + kGolden * (hi - lo);
      f2 = try_lag(x2);
    }
  }
  return best;
}

std::vector<double> rebuilt_speed(const Stair& st, const DroopFit& fit) {
  const auto load = lagged_force_kn(st.s.t_s, st.s.force_n, fit.tau_s);
  std::vector<double> v(st.s.t_s.size());
  const Eigen::Index c = st.first_col;
  for (std::size_t i = 0; i < v.size(); ++i) {
    const double u = (st.s.t_s[i] - st.s.t_s.front()) / st.span_s;
    v[i] =
        fit.x(c) + fit.x(0) * load[i] + (st.trend ? fit.x(c + 1) * u + fit.x(c + 2) * u * u : 0.0);
  }
  return v;
}

}  // namespace droop

namespace {

using droop::DroopFit;
using droop::kMaxMissSteps;
using droop::lagged_load;
using droop::largest_force_n;
using droop::Stair;

/// A droop under this many steps over the run is left to the held roller's fit.
constexpr double kMinDroopSteps = 0.5;

}  // namespace

RollerDroop drooping_roller_speed(const std::vector<double>& t_s, const std::vector<double>& v,
                                  const std::vector<double>& force_n, double roller_radius_m,
                                  double step_mps) {
  const std::size_t n = t_s.size();
  if (n < 20 || v.size() != n || force_n.size() != n || step_mps <= 0 || roller_radius_m <= 0)
    return {};
  // The staircase itself must droop: its mean over the samples under the top fifth of the load
  // at least half a step below its mean over the bottom fifth (averaged over the levels an
  // encoder's ripple dithers, a held roller's two means agree).
  {
    const auto load = lagged_load(t_s, force_n, 0.0);
    double lo_sum = 0, hi_sum = 0;
    std::size_t lo_n = 0, hi_n = 0;
    for (std::size_t i = 0; i < n; ++i) {
      if (load[i] < 0.2) lo_sum += v[i], ++lo_n;
      if (load[i] > 0.8) hi_sum += v[i], ++hi_n;
    }
    if (lo_n == 0 || hi_n == 0 ||
        !(lo_sum / static_cast<double>(lo_n) - hi_sum / static_cast<double>(hi_n) >=
          kMinDroopSteps * step_mps))
      return {};
  }
  std::vector<Stair> stairs{droop::read_stair({t_s, v, force_n, step_mps, roller_radius_m})};
  if (stairs.front().at.empty()) return {};
  const DroopFit fit = droop::fit_droop(stairs);
  // No finite fit, or one that misses the transitions (the speed moves in ways the model has
  // not: left to the channel's own rebuilding).
  if (fit.x.size() < 2 || !(fit.miss_steps() <= kMaxMissSteps)) return {};
  // A droop of under half a step is the held roller's (its staircase fit is unbiased there); a
  // roller does not speed up under the load it carries.
  const double f_max_kn = largest_force_n(force_n) * 1e-3;
  if (!(fit.mps_per_kn() * f_max_kn >= kMinDroopSteps * step_mps)) return {};
  RollerDroop out;
  out.v_ref_mps = droop::rebuilt_speed(stairs.front(), fit);
  out.mps_per_n = fit.mps_per_kn() * 1e-3;
  out.lag_s = fit.tau_s;
  return out;
}

}  // namespace brakefit::gap
