// A lag named on a roller whose drive droops: the drive's own lag behind the force was read from
// its quantised speed's transitions, a few of them on short runs, and a lag 0.1 s off moves the
// rebuilt roller (and the slip) as a pressure channel 10-20 ms late moves the force. A time
// offset, or a relaxation (at one roller speed the same lag), is named only where it beats every
// drive lag the transitions allow.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/gap/channels.hpp"
#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"

namespace brakefit::gap {

namespace {

/// How much more than the best lag's misfit at the transitions another may leave (x dof: an F of
/// about two standard errors of one parameter).
constexpr double kLagAllowedF = 4.0;

}  // namespace

std::vector<DroopLagAlternative> droop_lag_alternatives(const std::vector<Run>& runs) {
  const DroopLagProfile p = droop_lag_profile(runs);
  if (p.lag_rss.empty()) return {};
  double rss_min = INFINITY;
  for (const auto& lr : p.lag_rss) rss_min = std::min(rss_min, lr.second);
  const double allowed = rss_min * (1.0 + kLagAllowedF / p.dof);
  double lo = INFINITY, hi = -INFINITY;
  for (const auto& [tau_s, rss] : p.lag_rss)
    if (rss <= allowed && std::abs(tau_s - p.read_s) > 0.5 * p.step_s) {
      lo = std::min(lo, tau_s);
      hi = std::max(hi, tau_s);
    }
  std::vector<DroopLagAlternative> out;
  for (const double tau_s : {lo, hi}) {
    if (!std::isfinite(tau_s) || (!out.empty() && out.back().lag_s == tau_s)) continue;
    DroopLagAlternative alt{tau_s, runs};
    if (refit_droop_at(alt.runs, tau_s)) out.push_back(std::move(alt));
  }
  return out;
}

std::optional<MissingEvidence> lag_in_the_drive(const EffectScore& e, const std::vector<Run>& runs,
                                                const std::vector<Effect>& current,
                                                const Fitter& fit, const Options& o) {
  if (e.effect != Effect::TimeOffset && e.effect != Effect::RelaxationLength) return std::nullopt;
  const std::vector<DroopLagAlternative> alts = droop_lag_alternatives(runs);
  double best_n = INFINITY, best_lag_s = 0;
  for (const DroopLagAlternative& a : alts)
    if (const double h = heldout(a.runs, current, fit); h < best_n) {
      best_n = h;
      best_lag_s = a.lag_s;
    }
  if (!std::isfinite(best_n)) return std::nullopt;
  const double gain = 1.0 - e.heldout_rmse_after_n / std::max(best_n, 1e-12);
  if (gain >= o.gate_gain) return std::nullopt;
  double read_s = 0;
  for (const Run& r : runs)
    if (r.roller_droop_mps_per_n > 0) read_s = r.roller_droop_lag_s;
  return MissingEvidence{
      fmt::format("{} fits{{}} (held-out {:.1f} N, gain {:.3f}) but the roller's drive, its "
                  "droop read {:.2f} s behind the force instead of {:.2f} s (its speed's "
                  "transitions allow both), leaves {:.1f} N: the {} gains {:.3f} over that, under "
                  "the gate {:.3f}; a late channel and the drive's lag cannot be told apart on "
                  "these runs; not accepted",
                  to_string(e.effect), e.heldout_rmse_after_n, e.gain, best_lag_s, read_s, best_n,
                  to_string(e.effect), gain, o.gate_gain),
      "the drive's lag behind the force explains it alike"};
}

}  // namespace brakefit::gap
