// The evidence only one effect leaves, checked before a candidate that passed the gates is
// named: a fitted force cap must cut the curve while it still rises, a brake threshold must hold
// the wheel at its free-rolling slip while the pressure rises to it. A curve that is not a Magic
// Formula (a flat top, a steep foot) is fitted as well by either, and shows neither.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/gap/internal.hpp"

namespace brakefit::gap {

namespace {

/// The dead zone's evidence: the slip, above its value at rest, at the points of each run's rise
/// from rest whose force lies between kLo and kHi of the threshold (before it first passed the
/// threshold), against what the fitted curve's initial stiffness B C D gives at that force. A
/// dead zone keeps the wheel rolling free there (about 0); a steep foot of the curve moves it
/// (a fair share of 1). NaN: fewer than kMinPoints such points.
double dead_zone_slip_ratio(const std::vector<Run>& runs, double p0_bar, double stiffness_n) {
  constexpr double kLo = 0.25, kHi = 0.75;
  constexpr std::size_t kMinPoints = 10;
  double excess = 0, expected = 0;
  std::size_t points = 0;
  for (const Run& r : runs) {
    const double thr_n = r.brake_gain_n_per_bar * p0_bar;
    if (r.slip.empty() || !(thr_n > 0)) continue;
    const double rest = r.slip.front();
    for (std::size_t i = 0; i < r.slip.size() && r.force_n[i] <= thr_n; ++i) {
      if (r.force_n[i] < kLo * thr_n || r.force_n[i] > kHi * thr_n) continue;
      excess += r.slip[i] - rest;
      expected += r.force_n[i] / stiffness_n;
      ++points;
    }
  }
  return points >= kMinPoints && expected > 0 ? excess / expected : NAN;
}

}  // namespace

std::optional<MissingEvidence> missing_evidence(const EffectScore& e, const Fit& f,
                                                const std::vector<Run>& runs) {
  if (e.effect == Effect::CradleCap) {
    const double kink = cap_kink_ratio(runs, e.params[0].second);
    if (kink >= kCapMinEndSlopeRatio) return std::nullopt;
    return MissingEvidence{
        fmt::format("a force cap at {:.0f} N fits{{}} (held-out gain {:.3f}) but cannot be told "
                    "from a flat-topped curve: below it the force flattens gradually ({} of its "
                    "initial slope over its last 15 %; a cap cuts a curve still rising, at least "
                    "{:.0f} %); not accepted",
                    e.params[0].second, e.gain,
                    std::isfinite(kink) ? fmt::format("{:.0f} %", 100 * kink)
                                        : std::string("too few points to measure"),
                    100 * kCapMinEndSlopeRatio),
        "a flat-topped curve fits alike (no kink at the cap)"};
  }
  // On the roller only: on the ground the other brakes slow the vehicle during the rise and the
  // free wheel's slip moves with that (generator B's 3 bar ground dead zones read above the
  // limit); no limit has been measured there.
  const bool roller = std::all_of(runs.begin(), runs.end(),
                                  [](const Run& r) { return r.bench == can::BenchKind::Roller; });
  if (e.effect == Effect::BrakeThreshold && roller) {
    const double stiffness_n = f.params[0] * f.params[1] * f.params[2];
    const double ratio = dead_zone_slip_ratio(runs, e.params[0].second, stiffness_n);
    if (!(ratio > kDeadZoneMaxSlipRatio)) return std::nullopt;  // a dead zone, or no rise to see
    return MissingEvidence{
        fmt::format("a brake threshold of {:.2f} bar fits{{}} (held-out gain {:.3f}) but the wheel "
                    "did not roll free below it: while the pressure rose to it the slip moved "
                    "{:.0f} % as much as the fitted curve's initial stiffness gives (a dead zone "
                    "holds it, at most {:.0f} %); a curve steeper at its foot than a Magic "
                    "Formula fits alike; not accepted",
                    e.params[0].second, e.gain, 100 * ratio, 100 * kDeadZoneMaxSlipRatio),
        "the wheel did not roll free below the threshold"};
  }
  return std::nullopt;
}

}  // namespace brakefit::gap
