// Lag or delay, chosen again once the effects named after it are in the model. Forward
// selection picks between a relaxation length and a time offset in the round that names the
// first of them, before its partner is in the model: beside an effect it cannot fit yet (load
// transfer ending on its range's bound in round 1), the wrong one of the two can take the lead.
// Where the runs' speeds differ enough to tell them apart (a relaxation's lag is sigma / v, a
// time offset's one time), the twin is tried in its place, the other effects refitted beside it.
#include <fmt/format.h>

#include <algorithm>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"

namespace brakefit::gap {

std::optional<LagSwap> swap_lag_twin(const std::vector<Run>& runs,
                                     const std::vector<Effect>& chosen, double current_heldout_n,
                                     double gap_before_n, const Fit& base_fit, const Fitter& fit) {
  if (named_effects(chosen).size() < 2 || run_speed_spread(runs) < kSpeedFrictionMinSpeedSpread)
    return std::nullopt;
  for (Effect e : chosen) {
    const auto other = lag_twin(e);
    if (!other || std::find(chosen.begin(), chosen.end(), *other) != chosen.end()) continue;
    LagSwap s;
    s.replaced = e;
    s.model = chosen;
    std::replace(s.model.begin(), s.model.end(), e, *other);
    s.heldout_n = heldout(runs, s.model, fit);
    if (!(s.heldout_n < current_heldout_n)) return std::nullopt;
    s.fit = fit(pointers(runs), s.model);
    for (Effect m : s.model)
      if (!is_nuisance(m) && param_at_bound(s.model, m, s.fit)) return std::nullopt;
    s.score = score_at(*other, s.model, s.fit);
    s.score.gain = 1.0 - s.heldout_n / std::max(gap_before_n, 1e-12);
    s.score.delta_bic = s.fit.bic() - base_fit.bic();
    s.score.heldout_rmse_before_n = gap_before_n;
    s.score.heldout_rmse_after_n = s.heldout_n;
    if (missing_evidence(s.score, s.model, s.fit, runs)) return std::nullopt;
    s.score.accepted = true;
    s.score.decision = fmt::format("accepted in {}'s place (see the notes)", to_string(e));
    s.note = fmt::format(
        "{} was named before the effects after it were in the model; with them, {} in its place "
        "leaves {:.1f} N held out against {:.1f} N (the runs' speeds {:.1f}x apart tell a "
        "relaxation's lag, sigma / v, from a time offset's): {} is named instead",
        to_string(e), to_string(*other), s.heldout_n, current_heldout_n, run_speed_spread(runs),
        to_string(*other));
    return s;
  }
  return std::nullopt;
}

}  // namespace brakefit::gap
