#include "core/gap/warm_fit.hpp"

#include <algorithm>
#include <numeric>

#include "core/gap/internal.hpp"

namespace brakefit::gap {

WarmFitter::RunsKey WarmFitter::key_of(const std::vector<const Run*>& runs) {
  RunsKey key;
  key.reserve(runs.size());
  for (const Run* r : runs)
    key.emplace_back(r->t_s.size(), r->t_s.empty() ? 0.0 : r->t_s.front(),
                     std::accumulate(r->slip.begin(), r->slip.end(), 0.0),
                     std::accumulate(r->force_n.begin(), r->force_n.end(), 0.0));
  return key;
}

Fit WarmFitter::operator()(const std::vector<const Run*>& runs,
                           const std::vector<Effect>& effects) {
  Fit best = fit_runs(runs, effects, baseline_);
  if (Fit b = fit_runs(runs, effects, neutral_); b.ssr < best.ssr) best = std::move(b);
  RunsKey key = key_of(runs);
  // A third start once an effect is named (the nuisance terms alone are the baseline's start).
  if (!effects.empty()) {
    const std::vector<Effect> before(effects.begin(), effects.end() - 1);
    const bool named =
        std::any_of(before.begin(), before.end(), [](Effect e) { return !is_nuisance(e); });
    if (const auto it = fitted_.find({key, before}); named && it != fitted_.end())
      if (Fit w = fit_runs_from(runs, effects, it->second); w.ssr < best.ssr) best = std::move(w);
  }
  fitted_[{std::move(key), effects}] = best.params;
  return best;
}

}  // namespace brakefit::gap
