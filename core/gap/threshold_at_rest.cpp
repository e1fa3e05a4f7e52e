// A brake threshold beside a slip offset: in the linear region the dead zone and the foot's shift
// are one line, so held out a threshold gains nothing over the offset alone. The wheel at rest
// before the brake tells them apart: a slip offset reads there as itself, and an offset fitted
// below that rest (more force at a slip than the tyre gives) carries a threshold's force without
// slip. With the offset held at the rest, the threshold is fitted from the runs.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/gap/internal.hpp"

namespace brakefit::gap {

namespace {

/// Holds every fit's slip offset at the runs' pooled rest slip, within its uncertainty.
void pin_foot_at_rest(std::vector<Run>& runs) {
  const RestSlip rest = pooled_rest_slip(runs);
  for (Run& r : runs) {
    r.foot_pin_ratio = rest.mean;
    r.foot_pin_tol_ratio = std::max(rest.uncertainty, 1e-6);
  }
}

}  // namespace

std::optional<RestThreshold> threshold_at_rest(const std::vector<Run>& runs,
                                               const std::vector<Effect>& chosen,
                                               const Fit& current, double current_heldout_n,
                                               double noise_n, const Fitter& fit) {
  auto contains = [&](Effect e) { return param_offset(chosen, e).has_value(); };
  if (!contains(Effect::SlipOffset) || contains(Effect::BrakeThreshold) ||
      current.params.size() < 3)
    return std::nullopt;
  const RestSlip rest = pooled_rest_slip(runs);
  const double foot = fitted_foot_ratio(chosen, current);
  const double below = rest.mean - foot;
  const double force_n = current.slip_stiffness_n() * below;
  const double drag_n = kRestDragPeakRatio * std::abs(curve_of(current.params).D);
  if (rest.points < kOffsetMinRestPoints || below <= rest.uncertainty || force_n < drag_n)
    return std::nullopt;
  RestThreshold t;
  t.runs = runs;
  pin_foot_at_rest(t.runs);
  const std::vector<Run>& pinned = t.runs;
  t.model = chosen;
  t.model.push_back(Effect::BrakeThreshold);
  t.fit = fit(pointers(pinned), t.model);
  const std::size_t at = *param_offset(t.model, Effect::BrakeThreshold);
  const double p0_bar = t.fit.params.at(at);
  t.score.effect = Effect::BrakeThreshold;
  t.score.params = {{effect_param(Effect::BrakeThreshold).name, p0_bar}};
  if (at_bound(p0_bar, effect_param(Effect::BrakeThreshold))) return std::nullopt;
  if (missing_evidence(t.score, t.model, t.fit, pinned)) return std::nullopt;
  t.heldout_n = heldout(pinned, t.model, fit);
  if (t.heldout_n > (1.0 + kRestThresholdHeldoutSlack) * current_heldout_n) return std::nullopt;
  t.score.gain = 1.0 - t.heldout_n / std::max(current_heldout_n, 1e-12);
  t.score.delta_bic = t.fit.bic() - current.bic();
  t.score.heldout_rmse_before_n = current_heldout_n;
  t.score.heldout_rmse_after_n = t.heldout_n;
  t.note = fmt::format(
      "the slip offset was fitted at {:.3g}, {:.2g} below the slip the wheel rested at before the "
      "brake ({:.3g} +- {:.1g}, {} samples; an offset reads there as itself): {:.0f} N of force "
      "without slip ({:.1f}x the floor), which a brake threshold gives and the offset's line takes "
      "in the linear region. With the offset held at the rest a threshold of {:.2f} bar fits as "
      "well ({:.1f} N held out, {:.1f} N without it): both are named",
      foot, below, rest.mean, rest.uncertainty, rest.points, force_n, force_n / noise_n, p0_bar,
      t.heldout_n, current_heldout_n);
  t.score.decision =
      "accepted beside the slip offset: the wheel's rest shows its force without slip";
  return t;
}

}  // namespace brakefit::gap
