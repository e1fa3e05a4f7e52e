// The smallest magnitude of each effect a set's runs could show. An effect is in the runs only
// through its force beyond what the curve's own B, C, D, E can bend to take: a wheel's inertia
// on a roller at 2-6 km/h, where the wheel decelerates little before it runs away, leaves almost
// nothing else. Where an effect is not named, the report says from which magnitude it would have
// been expected: a user then knows whether "none" rules it out.
#include <fmt/format.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"

namespace brakefit::gap {

namespace {

/// An effect's magnitude where it is absent (a relaxation's range starts just above zero).
double absent_value(const EffectParam& p) {
  return std::clamp(0.0, p.lo, p.hi);
}

/// The one-parameter effects a reach is given for (load transfer has its stiffness ratio and
/// pitch too; a cradle cap is found from where the runs end, not as a small force).
bool has_reach(Effect e) {
  return effect_params(e).size() == 1 && e != Effect::CradleCap && !is_nuisance(e);
}

}  // namespace

std::vector<EffectReach> effect_reach(const std::vector<Run>& runs,
                                      const std::vector<double>& params,
                                      const std::vector<Effect>& model,
                                      const std::vector<Effect>& candidates, double noise_n,
                                      double gate_gain) {
  std::vector<EffectReach> out;
  std::size_t n = 0;
  for (const Run& r : runs) n += r.t_s.size();
  if (n <= params.size() || noise_n <= 0 || gate_gain <= 0 || gate_gain >= 1) return out;
  const Eigen::MatrixXd jac = prediction_jacobian(pointers(runs), params, model);
  // Each candidate is scored with the model's nuisance slip bias (the tyre's own shift, or a
  // quantised reference's bias) and, for the shift, without it, but credited only with what it
  // adds to the better of the two. The bias takes what it can of an effect's force within its
  // bound (a dead zone on a quantised roller reads as a foot shift): an effect shows against the
  // basis with the bias, or past the magnitude the bias takes at its bound against the basis
  // without it (a slip offset: past the bound itself).
  std::vector<Eigen::MatrixXd> bases{jac};
  std::vector<Eigen::Index> keep{0, 1, 2, 3}, bias;  // the curve's and effects', the bias's
  std::size_t at = 4;
  for (Effect b : model) {
    const std::size_t count = effect_params(b).size();
    for (std::size_t k = 0; k < count; ++k)
      (is_nuisance(b) ? bias : keep).push_back(static_cast<Eigen::Index>(at + k));
    at += count;
  }
  if (!bias.empty()) {
    Eigen::MatrixXd without(jac.rows(), static_cast<Eigen::Index>(keep.size()));
    for (std::size_t k = 0; k < keep.size(); ++k)
      without.col(static_cast<Eigen::Index>(k)) = jac.col(keep[k]);
    bases.push_back(std::move(without));
  }
  std::vector<Eigen::ColPivHouseholderQR<Eigen::MatrixXd>> solvers;
  solvers.reserve(bases.size());
  for (const auto& b : bases) solvers.push_back(b.colPivHouseholderQr());
  // A gap of the floor alone, plus the effect's remainder A: named where the held-out error falls
  // by the gain gate, floor <= (1 - g) sqrt(floor^2 + A^2).
  const double needed_n = noise_n * std::sqrt(1.0 / ((1 - gate_gain) * (1 - gate_gain)) - 1.0);
  for (Effect e : candidates) {
    if (!has_reach(e)) continue;
    // The effect's force per unit of its magnitude: the secant from absent to a step of 1 % of
    // its range's top (1 kg m^2, 0.3 bar, 3 ms, 0.02 m, 5e-4 of slip), the size it is sought at.
    const EffectParam& p = effect_params(e).front();
    const double off = absent_value(p), step = 0.01 * p.hi;
    std::vector<Effect> with = model;
    with.push_back(e);
    std::vector<double> on = params, none = params;
    on.push_back(off + step);
    none.push_back(off);
    Eigen::VectorXd unit(static_cast<Eigen::Index>(n));
    Eigen::Index row = 0;
    for (const Run& r : runs) {
      const std::vector<double> a = predict(r, on, with), b = predict(r, none, with);
      for (std::size_t i = 0; i < a.size(); ++i)
        unit(row + static_cast<Eigen::Index>(i)) = (a[i] - b[i]) / step;
      row += static_cast<Eigen::Index>(r.t_s.size());
    }
    // What of it the model cannot take: its residual after the least-squares projection on the
    // model's parameters (the curve's, the nuisances', the named effects').
    double smallest = INFINITY;
    const Eigen::VectorXd x = solvers[0].solve(unit);
    const Eigen::VectorXd left = unit - bases[0] * x;
    if (const double left_rms = std::sqrt(left.squaredNorm() / static_cast<double>(n));
        left_rms > 0 && std::isfinite(left_rms))
      smallest = needed_n / left_rms;
    if (bases.size() > 1) {
      // The nuisance slip per unit of the effect where the bias takes it, against its bound.
      double bias_per_unit = 0;
      for (Eigen::Index k : bias) bias_per_unit += std::abs(x(k));
      const double taken =
          bias_per_unit > 0 ? nuisance_bias_bound(pointers(runs), with) / bias_per_unit : 0.0;
      const Eigen::VectorXd rest = unit - bases[1] * solvers[1].solve(unit);
      const double rest_rms = std::sqrt(rest.squaredNorm() / static_cast<double>(n));
      if (rest_rms > 0 && std::isfinite(rest_rms) && std::isfinite(taken))
        smallest = std::min(smallest, taken + needed_n / rest_rms);
    }
    out.push_back({e, smallest});
  }
  return out;
}

double max_wheel_decel_mps2(const std::vector<Run>& runs) {
  double most = 0;
  for (const Run& r : runs)
    for (double a : r.wheel_accel_mps2) most = std::max(most, -a);
  return most;
}

std::string reach_note(const std::vector<EffectReach>& reach, double max_decel_mps2,
                       const std::vector<Effect>& model) {
  std::string named;
  for (Effect e : model)
    if (!is_nuisance(e)) named += fmt::format("{}{}", named.empty() ? "" : ", ", to_string(e));
  std::string each;
  for (const EffectReach& r : reach) {
    if (!std::isfinite(r.smallest)) continue;
    const double v = r.smallest;
    each += fmt::format("{}{} {} from {}", each.empty() ? "" : ", ", to_string(r.effect),
                        effect_params(r.effect).front().name,
                        v >= 10 ? fmt::format("{:.0f}", v) : fmt::format("{:.2g}", v));
  }
  if (each.empty()) return {};
  return fmt::format(
      "what these runs could show of each effect not named (its force beyond what the curve's B, "
      "C, D, E{} take, against the gain gate over the noise floor): {}; the wheel decelerates at "
      "up to {} m/s^2 before the runs end",
      named.empty() ? "" : fmt::format(" and the named {}", named), each,
      max_decel_mps2 >= 10 ? fmt::format("{:.0f}", max_decel_mps2)
                           : fmt::format("{:.2g}", max_decel_mps2));
}

}  // namespace brakefit::gap
