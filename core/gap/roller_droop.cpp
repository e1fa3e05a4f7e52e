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
#include <optional>
#include <utility>
#include <vector>

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

/// The lagged force in kN (the droop's column: one drive loses the same speed per newton in every
/// run of a station).
std::vector<double> lagged_force_kn(const std::vector<double>& t_s, const std::vector<double>& f,
                                    double tau_s) {
  auto y = lagged_load(t_s, f, tau_s);
  const double scale_kn = largest_force_n(f) * 1e-3;
  for (double& x : y) x *= scale_kn;
  return y;
}

/// A staircase as the fit reads it, not owned: a run's at conditioning, or one kept on a run.
struct StaircaseView {
  const std::vector<double>&t_s, &v_mps, &force_n;
  double step_mps, roller_radius_m;
};

StaircaseView view_of(const Run::RollerStaircase& s) {
  return {s.t_s, s.v_mps, s.force_n, s.step_mps, s.roller_radius_m};
}

/// One run's staircase as the fit reads it, and its columns: its own level, slow trend (u, u^2
/// over the run) and ripple harmonics; the droop's column is shared.
struct Stair {
  StaircaseView s;
  std::vector<std::size_t> at;  ///< the sample after each transition
  double mean_mps = 0, span_s = 1;
  bool trend = false;
  int harmonics = 0;
  Eigen::Index first_col = 0;  ///< its level's column
  Eigen::Index count() const { return 1 + (trend ? 2 : 0) + 2 * harmonics; }
  /// Its own columns' entries at time t and the droop's (in the shared column).
  void fill(Eigen::MatrixXd& a, Eigen::Index row, double t, double load_kn) const {
    const double u = (t - s.t_s.front()) / span_s;
    a(row, 0) = load_kn;
    Eigen::Index col = first_col;
    a(row, col++) = 1;
    if (trend) {
      a(row, col++) = u;
      a(row, col++) = u * u;
    }
    const double angle = mean_mps * (t - s.t_s.front()) / s.roller_radius_m;
    for (int h = 1; h <= harmonics; ++h) {
      a(row, col++) = std::cos(h * angle);
      a(row, col++) = std::sin(h * angle);
    }
  }
};

Stair read_stair(const StaircaseView& s) {
  Stair out{s, {}, 0, 1, false, 0, 0};
  const std::size_t n = s.t_s.size();
  for (std::size_t i = 1; i < n; ++i)
    if (s.v_mps[i] != s.v_mps[i - 1]) out.at.push_back(i);
  for (double x : s.v_mps) out.mean_mps += x / static_cast<double>(n);
  out.span_s = std::max(s.t_s.back() - s.t_s.front(), 1e-6);
  out.trend = out.at.size() >= kTrendTransitions;
  out.harmonics =
      out.at.size() >= kRippleTransitions &&
              out.mean_mps * out.span_s / (2 * M_PI * s.roller_radius_m) >= kHeldRollerMinTurns
          ? 2
          : 0;
  return out;
}

/// The droop fitted to the transitions of one or more runs of a station (each row in the steps of
/// its own channel): a level (trend, ripple) per run, one droop per kN behind one lag.
struct DroopFit {
  Eigen::VectorXd x;
  double rss_steps2 = INFINITY, tau_s = 0;
  Eigen::Index rows = 0, cols = 0;
  double mps_per_kn() const { return x.size() ? -x(0) : 0.0; }
  double miss_steps() const { return std::sqrt(rss_steps2 / static_cast<double>(rows)); }
};

/// The droop at the lag that meets the transitions best, or at fixed_tau_s where given.
DroopFit fit_droop(std::vector<Stair>& stairs, std::optional<double> fixed_tau_s = std::nullopt) {
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

/// A run's speed rebuilt from the fit: its level and trend, less the shared droop (its ripple is
/// the encoder's, not the roller's, and stays out).
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
  std::vector<Stair> stairs{read_stair({t_s, v, force_n, step_mps, roller_radius_m})};
  if (stairs.front().at.empty()) return {};
  const DroopFit fit = fit_droop(stairs);
  // No finite fit, or one that misses the transitions (the speed moves in ways the model has
  // not: left to the channel's own rebuilding).
  if (fit.x.size() < 2 || !(fit.miss_steps() <= kMaxMissSteps)) return {};
  // A droop of under half a step is the held roller's (its staircase fit is unbiased there); a
  // roller does not speed up under the load it carries.
  const double f_max_kn = largest_force_n(force_n) * 1e-3;
  if (!(fit.mps_per_kn() * f_max_kn >= kMinDroopSteps * step_mps)) return {};
  RollerDroop out;
  out.v_ref_mps = rebuilt_speed(stairs.front(), fit);
  out.mps_per_n = fit.mps_per_kn() * 1e-3;
  out.lag_s = fit.tau_s;
  return out;
}

namespace {

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
  for (const Run* r : fitted) out.stairs.push_back(read_stair(view_of(*r->roller_staircase)));
  std::vector<Stair> plain = out.stairs;
  for (Stair& st : plain) st.trend = false;
  out.fit = fit_droop(plain, fixed_tau_s);
  if (out.fit.x.size() >= 2 && out.fit.miss_steps() <= kMaxMissSteps)
    out.stairs = std::move(plain);
  else
    out.fit = fit_droop(out.stairs, fixed_tau_s);
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
    const auto v_full = rebuilt_speed(st, fit);
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
    if (r.bench == can::BenchKind::Roller && r.roller_droop_mps_per_n > 0 && r.roller_staircase)
      fitted.push_back(&r);
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

namespace {

bool droops(const Run& r) {
  return r.bench == can::BenchKind::Roller && r.roller_droop_mps_per_n > 0 && r.roller_staircase;
}

}  // namespace

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
    const DroopFit f = fit_droop(js.stairs, tau_s);
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
