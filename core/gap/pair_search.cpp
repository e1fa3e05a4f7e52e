// Two effects at once that neither explains alone: forward selection adds one effect per round
// and needs the first to pass the gates by itself. A dead zone under a long relaxation, or a
// heavy wheel under load transfer, bend the curve in ways that partly cancel: each alone fits
// badly (or the wrong way), and the set ends `unexplained`. When a structured gap is left, the
// leading candidates are fitted in pairs; a pair is named when it explains the gap and each
// member earns its place beside the other.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"

namespace brakefit::gap {

namespace {

/// Candidates from the leading round-1 scores by held-out gain and by BIC drop: a member of a
/// pair may fit badly held out alone (its partner's bend pulls it off) but still lower the
/// in-sample error a lot.
constexpr std::size_t kLeadersPerRanking = 3;
/// How many of the largest round-1 gains a candidate pushed to "no effect" is paired with.
constexpr std::size_t kPushedPartners = 2;

bool lag_and_delay(Effect a, Effect b) {
  return (a == Effect::RelaxationLength && b == Effect::TimeOffset) ||
         (a == Effect::TimeOffset && b == Effect::RelaxationLength);
}

bool inside(const std::vector<Effect>& model, Effect e, const Fit& f) {
  return param_offset(model, e) && !param_at_bound(model, e, f);
}

EffectScore member(Effect e, const std::vector<Effect>& model, const Fit& f) {
  EffectScore s;
  s.effect = e;
  const auto at = *param_offset(model, e);
  const auto eps = effect_params(e);
  for (std::size_t j = 0; j < eps.size(); ++j) s.params.emplace_back(eps[j].name, f.params[at + j]);
  return s;
}

}  // namespace

std::optional<PairFound> search_pairs(const std::vector<Run>& runs, const std::vector<Effect>& base,
                                      const std::vector<EffectScore>& round1, double gap_before_n,
                                      double left_n, const Fit& base_fit, const Fitter& fit,
                                      const Options& o) {
  std::vector<const EffectScore*> scored;
  for (const auto& s : round1)
    if (s.round == 0 && !is_nuisance(s.effect)) scored.push_back(&s);
  std::set<Effect> leaders;
  auto lead = [&](auto better) {
    std::vector<const EffectScore*> v = scored;
    std::sort(v.begin(), v.end(), better);
    for (std::size_t k = 0; k < std::min(kLeadersPerRanking, v.size()); ++k)
      leaders.insert(v[k]->effect);
  };
  lead([](const EffectScore* a, const EffectScore* b) { return a->gain > b->gain; });
  lead([](const EffectScore* a, const EffectScore* b) { return a->delta_bic < b->delta_bic; });
  // A candidate whose fit alone stopped at "no effect" (a one-sided magnitude at 0): the data
  // pushed it past none, as a partner bending the curve the other way does (a heavy wheel under
  // a lag: alone, a lag reads as a negative inertia). Paired with the largest gains only.
  std::set<Effect> pushed;
  for (const auto* s : scored) {
    const EffectParam ep = effect_param(s->effect);
    if (ep.lo_is_physical && ep.lo == 0.0 && !s->params.empty() && s->params.front().second <= 0.0)
      pushed.insert(s->effect);
  }
  std::vector<const EffectScore*> by_gain = scored;
  std::sort(by_gain.begin(), by_gain.end(),
            [](const EffectScore* a, const EffectScore* b) { return a->gain > b->gain; });
  std::vector<std::pair<Effect, Effect>> pairs;
  {
    const std::vector<Effect> pool(leaders.begin(), leaders.end());
    for (std::size_t i = 0; i < pool.size(); ++i)
      for (std::size_t k = i + 1; k < pool.size(); ++k) pairs.emplace_back(pool[i], pool[k]);
    for (Effect e : pushed)
      for (std::size_t k = 0; k < std::min(kPushedPartners, by_gain.size()); ++k)
        if (!leaders.contains(e) && by_gain[k]->effect != e)
          pairs.emplace_back(by_gain[k]->effect, e);
  }
  auto alone_n = [&](Effect e) {  // the effect's held-out error alone (round 1)
    for (const auto* s : scored)
      if (s->effect == e) return s->heldout_rmse_after_n;
    return gap_before_n;
  };
  std::optional<PairFound> best;
  for (const auto& [a, b] : pairs) {
    if (lag_and_delay(a, b)) continue;
    std::vector<Effect> model = base;
    model.push_back(a);
    model.push_back(b);
    Fit f = fit(pointers(runs), model);
    if (!inside(model, a, f) || !inside(model, b, f)) continue;
    const double h = heldout(runs, model, fit);
    if (best && h >= best->heldout_n) continue;
    PairFound p;
    p.model = model;
    p.heldout_n = h;
    p.gain = 1.0 - h / std::max(gap_before_n, 1e-12);
    p.delta_bic = f.bic() - base_fit.bic();
    // Each member's place: the pair against the other member alone.
    p.gain_over_a = 1.0 - h / std::max(alone_n(b), 1e-12);
    p.gain_over_b = 1.0 - h / std::max(alone_n(a), 1e-12);
    p.a = member(a, model, f);
    p.b = member(b, model, f);
    p.fit = std::move(f);
    best = std::move(p);
  }
  if (!best) return std::nullopt;
  PairFound& p = *best;
  // The member that contributes more is named first (the verdict's order is the model's).
  if (p.gain_over_b > p.gain_over_a) {
    // a's and b's blocks are the fit's last two, side by side: b's goes first.
    const auto at_a = static_cast<std::ptrdiff_t>(*param_offset(p.model, p.a.effect));
    const auto at_b = static_cast<std::ptrdiff_t>(*param_offset(p.model, p.b.effect));
    const auto end = at_b + static_cast<std::ptrdiff_t>(effect_params(p.b.effect).size());
    for (auto* v : {&p.fit.params, &p.fit.stderr_})
      if (static_cast<std::ptrdiff_t>(v->size()) >= end)
        std::rotate(v->begin() + at_a, v->begin() + at_b, v->begin() + end);
    std::swap(p.model[p.model.size() - 1], p.model[p.model.size() - 2]);
    std::swap(p.a, p.b);
    std::swap(p.gain_over_a, p.gain_over_b);
  }
  // Named only when the pair explains the gap as a first effect must (the fit-quality share),
  // does better than forward selection by the gain gate, passes the BIC margin for its two
  // effects, and neither member could be dropped.
  const bool passes = p.gain >= o.min_first_gain && p.heldout_n <= (1.0 - o.gate_gain) * left_n &&
                      p.delta_bic <= -2.0 * o.bic_margin && p.gain_over_a >= o.gate_gain &&
                      p.gain_over_b >= o.gate_gain;
  if (!passes) return std::nullopt;
  for (EffectScore* m : {&p.a, &p.b}) {
    m->gain = p.gain;
    m->delta_bic = p.delta_bic;
    m->heldout_rmse_before_n = gap_before_n;
    m->heldout_rmse_after_n = p.heldout_n;
    if (missing_evidence(*m, p.model, p.fit, runs)) return std::nullopt;
  }
  return best;
}

}  // namespace brakefit::gap
