// A roller whose drive slows under the brake's load (the motor's slip; a few % with a heavy
// vehicle), read through a quantised channel: its speed rebuilt as a level, a droop following the
// brake's force behind a lag, a slow trend and the encoder's ripple, fitted to where the staircase
// steps (there the speed crossed the middle of the two levels). A fit to the staircase itself is
// unbiased only where a ripple of a step or more dithers the levels; a droop of two or three steps
// over a short run leaves a few transitions and long stretches on one level, where the
// staircase's least squares put the speed half a step off (a slip error of 5e-4 at 1.1 m/s).
#include <fmt/format.h>
#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>

#include "core/gap/internal.hpp"

namespace brakefit::gap {

namespace {

/// The droop's lags tried (s): a roller's motor and flywheel settle in 0.1-0.4 s.
constexpr std::array<double, 5> kDroopLags{0.0, 0.05, 0.1, 0.2, 0.4};
/// Golden-section steps refining the lag between the grid's points (0.4 s to 1 ms in 12).
constexpr int kDroopLagRefinements = 12;
/// Transitions needed for the slow trend's two columns, and for the ripple's four.
constexpr std::size_t kTrendTransitions = 20, kRippleTransitions = 16;
/// A droop under this many steps over the run is left to the held roller's fit.
constexpr double kMinDroopSteps = 0.5;
/// The fit's RMS miss at the transitions, in steps, above which the model is not the roller's.
constexpr double kMaxMissSteps = 0.35;
/// A run read as held takes a station's droop only where it droops by at most this many steps
/// over the run (more, and its staircase would have shown it).
constexpr double kMaxSharedDroopSteps = 1.0;

/// The largest force's magnitude: the scale lagged_load's 0-1 is over.
double largest_force_n(const std::vector<double>& f) {
  double f_max = 0;
  for (double x : f) f_max = std::max(f_max, std::abs(x));
  return f_max;
}

/// The force behind a first-order lag, over the largest force (0-1).
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

struct Columns {
  bool trend = false;
  int harmonics = 0;
  Eigen::Index count() const { return 2 + (trend ? 2 : 0) + 2 * harmonics; }
};

/// One row: level, droop, [u, u^2], [ripple harmonics].
void fill_row(Eigen::MatrixXd& a, Eigen::Index row, const Columns& c, double load, double u,
              double angle) {
  a(row, 0) = 1;
  a(row, 1) = load;
  Eigen::Index col = 2;
  if (c.trend) {
    a(row, col++) = u;
    a(row, col++) = u * u;
  }
  for (int h = 1; h <= c.harmonics; ++h) {
    a(row, col++) = std::cos(h * angle);
    a(row, col++) = std::sin(h * angle);
  }
}

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
  std::vector<std::size_t> at;  // the sample after each transition
  for (std::size_t i = 1; i < n; ++i)
    if (v[i] != v[i - 1]) at.push_back(i);
  if (at.empty()) return {};
  double mean = 0;
  for (double x : v) mean += x / static_cast<double>(n);
  const double span = std::max(t_s.back() - t_s.front(), 1e-6);
  Columns cols;
  cols.trend = at.size() >= kTrendTransitions;
  cols.harmonics = at.size() >= kRippleTransitions &&
                           mean * span / (2 * M_PI * roller_radius_m) >= kHeldRollerMinTurns
                       ? 2
                       : 0;
  // One row more: the roller before the brake (its first level, at the load there) pins the
  // level where a droop of a step or two crossed one boundary only.
  const auto m = static_cast<Eigen::Index>(at.size()) + 1;
  Eigen::VectorXd best;
  double best_rss = INFINITY, best_tau = 0;
  auto try_lag = [&](double tau_s) {
    const auto load = lagged_load(t_s, force_n, tau_s);
    Eigen::MatrixXd a(m, cols.count());
    Eigen::VectorXd b(m);
    for (Eigen::Index k = 0; k + 1 < m; ++k) {
      const std::size_t i = at[static_cast<std::size_t>(k)];
      const double tc = 0.5 * (t_s[i] + t_s[i - 1]);
      fill_row(a, k, cols, 0.5 * (load[i] + load[i - 1]), (tc - t_s.front()) / span,
               mean * (tc - t_s.front()) / roller_radius_m);
      b(k) = 0.5 * (v[i] + v[i - 1]);
    }
    fill_row(a, m - 1, cols, load.front(), 0.0, 0.0);
    b(m - 1) = v.front();
    const Eigen::VectorXd x = a.colPivHouseholderQr().solve(b);
    const double rss = (a * x - b).squaredNorm();
    if (rss < best_rss) {
      best_rss = rss;
      best = x;
      best_tau = tau_s;
    }
    return rss;
  };
  for (double tau_s : kDroopLags) try_lag(tau_s);
  // The lag between the grid's neighbours of the best, by golden section: on a fast pedal ramp
  // the drive's speed falls at up to 20 mm/s^2, and a lag 50 ms off puts the rebuilt speed a
  // millimetre per second off (a slip error of 1e-3 at 4 km/h, more than a wheel's inertia leaves).
  {
    const auto it = std::find(kDroopLags.begin(), kDroopLags.end(), best_tau);
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
  }
  // No finite fit, or one that misses the transitions (the speed moves in ways the model has
  // not: left to the channel's own rebuilding).
  if (best.size() < 2 ||
      !(std::sqrt(best_rss / static_cast<double>(m)) <= kMaxMissSteps * step_mps))
    return {};
  // A droop of under half a step is the held roller's (its staircase fit is unbiased there); a
  // roller does not speed up under the load it carries.
  if (!(-best(1) >= kMinDroopSteps * step_mps)) return {};
  const auto load = lagged_load(t_s, force_n, best_tau);
  RollerDroop out;
  out.v_ref_mps.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double u = (t_s[i] - t_s.front()) / span;
    out.v_ref_mps[i] =
        best(0) + best(1) * load[i] + (cols.trend ? best(2) * u + best(3) * u * u : 0.0);
  }
  out.mps_per_n = -best(1) / largest_force_n(force_n);  // lagged_load's scale
  out.lag_s = best_tau;
  return out;
}

std::string share_roller_droop(std::vector<Run>& runs) {
  std::vector<const Run*> fitted;
  for (const Run& r : runs)
    if (r.bench == can::BenchKind::Roller && r.roller_droop_mps_per_n > 0) fitted.push_back(&r);
  if (fitted.empty()) return {};
  std::sort(fitted.begin(), fitted.end(), [](const Run* a, const Run* b) {
    return a->roller_droop_mps_per_n < b->roller_droop_mps_per_n;
  });
  const Run& median = *fitted[fitted.size() / 2];
  const double k = median.roller_droop_mps_per_n, tau_s = median.roller_droop_lag_s;
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
  if (changed == 0) return {};
  return fmt::format(
      "the roller's drive droops under the brake's force ({:.3g} mm/s per kN behind a {:.2f} s "
      "lag, the median of {} run(s) whose quantised speed stepped with it): {} run(s) whose droop "
      "stayed within a step of the channel, read as held, took it (at most {:.2f} mm/s){}",
      1e6 * k, tau_s, fitted.size(), changed, 1e3 * largest_mps,
      refused ? fmt::format("; {} held run(s) would have drooped by more than a step and did not "
                            "take it",
                            refused)
              : std::string());
}

}  // namespace brakefit::gap
