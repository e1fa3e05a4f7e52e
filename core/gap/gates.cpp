// The gates a candidate passes to be named (calibrated per condition on null sets), what a
// parameter at its range's end is, and whether a fit leaves structure the gates must not name.
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"

namespace brakefit::gap {

// Gates (see calibrated_options): max(0.10, 1.5 x the largest null gain) and max(10, 1.5 x the
// largest null BIC drop) over 30 null sets per condition (bench/gap_referee --calibrate 30).
// Null maxima measured 2026-11-21: roller gain 0.005, dBIC -2.4; ground 0.013, -10.1; roller vs
// road 0.146, -305.8 (the roller fit carried to the road leaves a small bias every transfer
// candidate nibbles at).
constexpr double kRollerGateGain = 0.10, kRollerBicMargin = 10.0;
constexpr double kGroundGateGain = 0.10, kGroundBicMargin = 16.0;
constexpr double kTransferGateGain = 0.22, kTransferBicMargin = 460.0;

Options calibrated_options(Condition c, Options base) {
  // Seeds of the null sets 1 000 000+, disjoint from the referee's.
  switch (c) {
    case Condition::Roller:
      base.gate_gain = kRollerGateGain;
      base.bic_margin = kRollerBicMargin;
      break;
    case Condition::Ground:
      base.gate_gain = kGroundGateGain;
      base.bic_margin = kGroundBicMargin;
      break;
    case Condition::RollerToRoad:
      base.gate_gain = kTransferGateGain;
      base.bic_margin = kTransferBicMargin;
      break;
  }
  return base;
}

double bic_margin_for(const Options& o, std::size_t points) {
  return std::max(o.bic_margin, o.bic_margin_per_point * static_cast<double>(points));
}

bool at_bound(double v, const EffectParam& p) {
  const double tol = 0.005 * (p.hi - p.lo);
  return (!p.lo_is_physical && v <= p.lo + tol) || v >= p.hi - tol;
}

std::optional<std::size_t> param_at_bound(const std::vector<Effect>& model, Effect e,
                                          const Fit& f) {
  const auto at = param_offset(model, e);
  const auto eps = effect_params(e);
  for (std::size_t j = 0; at && j < eps.size(); ++j)
    if (at_bound(f.params.at(*at + j), eps[j])) return j;
  return std::nullopt;
}

std::optional<std::size_t> undamped_pitch(const std::vector<Effect>& model, Effect e,
                                          const Fit& f) {
  // A body's pitch mode is damped (its dampers: 0.2-0.7 of critical): a mode at a body's
  // frequency or slower with next to no damping is a swing the load never makes, and its lag,
  // the damping's parameter, sits at the end of the range a vehicle allows (a fading tyre's
  // friction was read as a load following a 0.76 Hz mode at damping 0). Judged on the fit that
  // chooses the load, not on refits beside later effects: three 50 Hz runs of a car damped at
  // 0.55 chose it at 0.09, and beside a wheel's inertia at zero the refit put the damping at 0.
  const auto at = param_offset(model, e);
  if (!at || !is_load_transfer(e)) return std::nullopt;
  const std::size_t lag = effect_params(e).size() - 2, mode = lag + 1;
  const double lag_s = f.params.at(*at + lag), mode_s2 = f.params.at(*at + mode);
  if (mode_s2 >= kBodyPitchModeMinS2 && lag_s < 2.0 * kPitchMinDamping * std::sqrt(mode_s2))
    return lag;
  return std::nullopt;
}

std::optional<std::string> named_at_range_end(const std::vector<Effect>& model, const Fit& f) {
  const std::vector<Effect> named = named_effects(model);
  std::vector<std::string> names;
  names.reserve(named.size());
  for (Effect e : named) names.emplace_back(to_string(e));
  for (Effect e : named) {
    const auto j = param_at_bound(model, e, f);
    if (!j) continue;
    return fmt::format(
        "the model naming {} explains the runs only with {}'s {} at the end of its physical "
        "range ({:.4g}) once fitted as named: not a physical account, so no effect is named",
        fmt::join(names, ", "), to_string(e), effect_params(e)[*j].name,
        f.params.at(*param_offset(model, e) + *j));
  }
  return std::nullopt;
}

double structure_left_share(double before_n, double after_n, double noise_n) {
  const double before = before_n * before_n - noise_n * noise_n;
  if (!(before > 0)) return 1.0;
  return std::sqrt(std::max(0.0, after_n * after_n - noise_n * noise_n) / before);
}

bool structured_gap_left(double before_n, double after_n, double noise_n, const Options& o) {
  return after_n > o.noise_factor * noise_n ||
         (after_n > o.structure_floor_share * o.noise_factor * noise_n &&
          structure_left_share(before_n, after_n, noise_n) > o.max_structure_left_share);
}

bool nibbled_alike(double first_gain, double rival_gain, double before_n, double noise_n,
                   const Options& o) {
  return first_gain < o.min_first_gain && rival_gain >= o.gate_gain &&
         first_gain - rival_gain < o.separability * first_gain &&
         before_n > std::sqrt(2.0) * noise_n;
}

FitQuality fit_quality(double first_gain, double runner_up_gain, double before_n, double after_n,
                       double noise_n, bool law_in_part, const Options& o) {
  // A structured gap is left above noise_factor x the floor, or where most of the structure
  // beyond the noise is still there and what is left lies clear of the floor's own scatter: a
  // curve that is not a Magic Formula, whose structure is a few times the noise, is left under
  // noise_factor x the floor by a candidate that takes a small bite of it.
  if (!structured_gap_left(before_n, after_n, noise_n, o) || first_gain >= o.min_first_gain)
    return FitQuality::Explained;
  // One bite, not a nibble: a curve that is not a Magic Formula lets several candidates (a cap,
  // a threshold, an offset) nibble alike, while a real effect that its law matches only in part
  // (a tyre's own load laws under a strong load transfer) stands alone. Only for such a law: a
  // lag or a threshold that fits in part is not that effect (a brush-model tyre on a roller let
  // a time offset take 27 % of its gap, 6.8x any other candidate).
  if (law_in_part && first_gain >= o.gate_gain &&
      first_gain >= o.min_bite_over_runner_up * runner_up_gain)
    return FitQuality::OneBite;
  return FitQuality::Nibble;
}

}  // namespace brakefit::gap
