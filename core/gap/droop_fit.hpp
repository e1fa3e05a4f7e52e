// The drooping roller's staircase fit, shared by one run's fit (roller_droop.cpp) and a
// station's runs fitted together (station_droop.cpp): each run's staircase with its own columns
// (a level, a slow trend, the encoder's ripple) beside one droop per kN behind one lag, fitted
// to where the staircase steps.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <cstddef>
#include <optional>
#include <vector>

#include "core/gap/internal.hpp"

namespace brakefit::gap::droop {

/// The droop's lags tried (s): a roller's motor and flywheel settle in 0.1-0.4 s.
constexpr std::array<double, 5> kDroopLags{0.0, 0.05, 0.1, 0.2, 0.4};
/// The fit's RMS miss at the transitions, in steps, above which the model is not the roller's.
constexpr double kMaxMissSteps = 0.35;

/// The largest force's magnitude: the scale lagged_load's 0-1 is over.
double largest_force_n(const std::vector<double>& f);
/// The force behind a first-order lag, over the largest force (0-1).
std::vector<double> lagged_load(const std::vector<double>& t_s, const std::vector<double>& f,
                                double tau_s);

/// A staircase as the fit reads it, not owned: a run's at conditioning, or one kept on a run.
struct StaircaseView {
  const std::vector<double>&t_s, &v_mps, &force_n;
  double step_mps, roller_radius_m;
};

inline StaircaseView view_of(const Run::RollerStaircase& s) {
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

/// The droop fitted to the transitions of one or more runs of a station (each row in the steps of
/// its own channel): a level (trend, ripple) per run, one droop per kN behind one lag.
struct DroopFit {
  Eigen::VectorXd x;
  double rss_steps2 = INFINITY, tau_s = 0;
  Eigen::Index rows = 0, cols = 0;
  double mps_per_kn() const { return x.size() ? -x(0) : 0.0; }
  double miss_steps() const { return std::sqrt(rss_steps2 / static_cast<double>(rows)); }
};

/// One run's staircase read: its transitions, mean speed and span, and which of its own columns
/// its transitions can carry (the trend's, the ripple's).
Stair read_stair(const StaircaseView& s);
/// The droop at the lag that meets the transitions best, or at fixed_tau_s where given.
DroopFit fit_droop(std::vector<Stair>& stairs, std::optional<double> fixed_tau_s = std::nullopt);
/// A run's speed rebuilt from the fit: its level and trend, less the shared droop (its ripple is
/// the encoder's, not the roller's, and stays out).
std::vector<double> rebuilt_speed(const Stair& st, const DroopFit& fit);

}  // namespace brakefit::gap::droop
