// The smallest wheel inertia a set's runs could show. A wheel's inertial force, I a / R^2, is in
// the runs only where the wheel decelerates (on a roller at 2-6 km/h, mostly in the last tenths
// of a second before the cut), and the part of it that the curve's own B, C, D, E can bend to
// take is no evidence at all. Where no inertia is named, the report says from which inertia on
// it would have been expected: a user then knows whether "none" rules an inertia out.
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"

namespace brakefit::gap {

InertiaReach inertia_reach(const std::vector<Run>& runs, const std::vector<double>& params,
                           const std::vector<Effect>& effects, double noise_n, double gate_gain) {
  InertiaReach out;
  std::size_t n = 0;
  for (const Run& r : runs) n += r.t_s.size();
  const auto p_count = static_cast<Eigen::Index>(params.size());
  if (n <= params.size() || noise_n <= 0 || gate_gain <= 0 || gate_gain >= 1) return out;
  // The unit inertia's force per point (N per kg m^2) and the baseline's Jacobian, by central
  // differences of its prediction.
  Eigen::VectorXd unit(static_cast<Eigen::Index>(n));
  Eigen::MatrixXd jac(static_cast<Eigen::Index>(n), p_count);
  Eigen::Index row = 0;
  for (const Run& r : runs) {
    const double r2 = r.wheel_radius_m * r.wheel_radius_m;
    for (std::size_t i = 0; i < r.t_s.size(); ++i) {
      unit(row + static_cast<Eigen::Index>(i)) = r.wheel_accel_mps2[i] / r2;
      out.max_decel_mps2 = std::max(out.max_decel_mps2, -r.wheel_accel_mps2[i]);
    }
    for (Eigen::Index j = 0; j < p_count; ++j) {
      std::vector<double> hi = params, lo = params;
      const double h = 1e-4 * std::max(std::abs(params[static_cast<std::size_t>(j)]), 1e-3);
      hi[static_cast<std::size_t>(j)] += h;
      lo[static_cast<std::size_t>(j)] -= h;
      const std::vector<double> up = predict(r, hi, effects), down = predict(r, lo, effects);
      for (std::size_t i = 0; i < up.size(); ++i)
        jac(row + static_cast<Eigen::Index>(i), j) = (up[i] - down[i]) / (2 * h);
    }
    row += static_cast<Eigen::Index>(r.t_s.size());
  }
  // What of the inertia's force the curve cannot take: its residual after the least-squares
  // projection on the baseline's parameters.
  const Eigen::VectorXd taken = jac * jac.colPivHouseholderQr().solve(unit);
  const double left_rms = std::sqrt((unit - taken).squaredNorm() / static_cast<double>(n));
  if (!(left_rms > 0) || !std::isfinite(left_rms)) return out;
  // A gap of the floor alone, plus the inertia's remainder A: named where the held-out error
  // falls by the gain gate, floor <= (1 - g) sqrt(floor^2 + A^2).
  const double needed_n = noise_n * std::sqrt(1.0 / ((1 - gate_gain) * (1 - gate_gain)) - 1.0);
  out.smallest_kgm2 = needed_n / left_rms;
  return out;
}

std::string inertia_reach_note(const InertiaReach& reach) {
  if (!std::isfinite(reach.smallest_kgm2)) return {};
  const auto two_figures = [](double v) {
    return v >= 10 ? fmt::format("{:.0f}", v) : fmt::format("{:.2g}", v);
  };
  return fmt::format(
      "no wheel inertia is named; these runs could show one only from about {} kg m^2: the wheel "
      "decelerates at up to {} m/s^2 before the runs end, and the curve's B, C, D, E take most "
      "of the inertia's force, I a / R^2 (a smaller inertia leaves less than the gain gate over "
      "the noise floor)",
      two_figures(reach.smallest_kgm2), two_figures(reach.max_decel_mps2));
}

}  // namespace brakefit::gap
