// Two effects at once that neither explains alone: forward selection adds one effect per round
// and needs the first to pass the gates by itself. A dead zone under a long relaxation, or a
// heavy wheel under load transfer, bend the curve in ways that partly cancel: each alone fits
// badly (or the wrong way), and the set ends `unexplained`. When a structured gap is left, the
// candidates are fitted in pairs; the best pair held out that explains the gap, with each
// member earning its place beside the other, is named.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <set>
#include <tuple>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"

namespace brakefit::gap {

namespace {

bool lag_and_delay(Effect a, Effect b) {
  return (a == Effect::RelaxationLength && b == Effect::TimeOffset) ||
         (a == Effect::TimeOffset && b == Effect::RelaxationLength);
}

bool inside(const std::vector<Effect>& model, Effect e, const Fit& f) {
  return param_offset(model, e) && !param_at_bound(model, e, f);
}

/// Puts the member that contributes more first (the verdict's order is the model's), then
/// names the pair only when it explains the gap as a first effect must (the fit-quality share),
/// does better than forward selection by the gain gate, passes the BIC margin for its two
/// effects, neither member could be dropped, and each has the evidence only it leaves. Returns
/// why it is not named (nothing: it is).
struct Refusal {
  PairRule rule;
  std::string why;
};
std::optional<Refusal> refusal(PairFound& p, double gap_before_n, double left_n,
                               const std::vector<Run>& runs, const Options& o) {
  const bool lt_first = is_load_transfer(p.b.effect) && !is_load_transfer(p.a.effect);
  if (p.in_sample ? lt_first : p.gain_over_b > p.gain_over_a) {
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
  const double after_n = p.in_sample ? p.in_sample_n : p.heldout_n;
  const double margin = 2.0 * bic_margin_for(o, p.fit.points);
  if (p.gain < o.min_first_gain)
    return Refusal{PairRule::ShareOfGap,
                   fmt::format("explains {:.0f} % of the gap, under the {:.0f} % a pair must",
                               100 * p.gain, 100 * o.min_first_gain)};
  if (after_n > (1.0 - o.gate_gain) * left_n)
    return Refusal{PairRule::GainOverSelection,
                   fmt::format("leaves {:.1f} N: not the gain gate ({:.3f}) below the {:.1f} N "
                               "forward selection left",
                               after_n, o.gate_gain, left_n)};
  if (p.delta_bic > -margin)
    return Refusal{
        PairRule::BicMargin,
        fmt::format("BIC drop {:.1f}, under twice the margin ({:.1f})", -p.delta_bic, margin)};
  for (const auto& [m, other, g] :
       {std::tuple{&p.a, &p.b, p.gain_over_a}, std::tuple{&p.b, &p.a, p.gain_over_b}})
    if (g < o.gate_gain)
      return Refusal{PairRule::MemberGain,
                     fmt::format("{} adds {:.3f} over {} alone, under the gain gate {:.3f}",
                                 to_string(m->effect), g, to_string(other->effect), o.gate_gain)};
  for (EffectScore* m : {&p.a, &p.b}) {
    m->gain = p.gain;
    m->delta_bic = p.delta_bic;
    m->heldout_rmse_before_n = gap_before_n;
    m->heldout_rmse_after_n = after_n;
    if (const auto missing = missing_evidence(*m, p.model, p.fit, runs))
      return Refusal{PairRule::Evidence,
                     fmt::format("{}: {}", to_string(m->effect), missing->decision)};
  }
  return std::nullopt;
}

bool passes(PairFound& p, double gap_before_n, double left_n, const std::vector<Run>& runs,
            const Options& o) {
  return !refusal(p, gap_before_n, left_n, runs, o);
}

/// The pair as the report lists it.
PairScore pair_score(const PairFound& p, double before_n, PairRule rule, std::string decision) {
  PairScore s;
  s.rule = rule;
  s.accepted = rule == PairRule::Named;
  s.a = p.a;
  s.b = p.b;
  s.rmse_before_n = before_n;
  s.rmse_after_n = p.in_sample ? p.in_sample_n : p.heldout_n;
  s.gain = p.gain;
  s.gain_over_a = p.gain_over_a;
  s.gain_over_b = p.gain_over_b;
  s.delta_bic = p.delta_bic;
  s.in_sample = p.in_sample;
  s.decision = std::move(decision);
  return s;
}

/// A member that another candidate replaces beside the same partner, the pair passing and
/// explaining the gap within the separability share, is not told apart from it: the report says
/// so, as it does of two single effects (a time offset with a slip offset and with a brake
/// threshold: both are a shift at the curve's foot, and the threshold fitted 0.89 of the gap
/// where the offset fitted 0.88). Only the best replacement of each member is noted.
void note_alike_members(PairFound& p, const std::vector<PairFound>& pool, double gap_before_n,
                        double left_n, const std::vector<Run>& runs, const Options& o) {
  std::set<Effect> noted;
  for (const PairFound& q : pool) {
    if (&q == &p) continue;
    const std::array<Effect, 2> mine{p.a.effect, p.b.effect}, theirs{q.a.effect, q.b.effect};
    for (std::size_t i = 0; i < 2; ++i)
      for (std::size_t k = 0; k < 2; ++k) {
        const Effect kept = mine[1 - i], replaced = mine[i], by = theirs[1 - k];
        if (theirs[k] != kept || by == replaced || by == kept || noted.count(replaced)) continue;
        if (p.gain - q.gain >= o.separability * p.gain) continue;
        PairFound copy = q;
        if (!passes(copy, gap_before_n, left_n, runs, o)) continue;
        noted.insert(replaced);
        p.notes.push_back(fmt::format(
            "the data cannot separate {} from {} beside {}: the pair with either explains the gap "
            "alike (held-out gains {:.3f} and {:.3f}; in its place {} {:.3g})",
            to_string(replaced), to_string(by), to_string(kept), p.gain, q.gain,
            effect_param(by).name, q.fit.params[*param_offset(q.model, by)]));
      }
  }
}

}  // namespace

const char* to_string(PairRule r) {
  switch (r) {
    case PairRule::Named:
      return "named";
    case PairRule::ShareOfGap:
      return "share_of_gap";
    case PairRule::GainOverSelection:
      return "gain_over_selection";
    case PairRule::BicMargin:
      return "bic_margin";
    case PairRule::MemberGain:
      return "member_gain";
    case PairRule::Evidence:
      return "evidence";
    case PairRule::RangeEnd:
      return "range_end";
    case PairRule::OverFloor:
      return "over_floor";
    case PairRule::AnotherNamed:
      return "another_named";
  }
  return "?";
}

std::optional<PairFound> search_pairs(const std::vector<Run>& runs, const std::vector<Effect>& base,
                                      const std::vector<EffectScore>& round1, double gap_before_n,
                                      double left_n, const Fit& base_fit, const Fitter& fit,
                                      double noise_n, std::optional<double> left_in_sample_n,
                                      const Options& o, std::vector<PairScore>& tried) {
  std::vector<const EffectScore*> scored;
  for (const auto& s : round1)
    if (s.round == 0 && !is_nuisance(s.effect)) scored.push_back(&s);
  // Every pair of round 1's candidates: a member may fit badly alone, held out and in sample
  // (a time offset beside a slip offset fits a third of its delay, the offset's BIC drop ranks
  // fifth of seven), so no ranking of the singles is sure to hold both.
  std::set<Effect> pool;
  for (const auto* s : scored) pool.insert(s->effect);
  std::vector<std::pair<Effect, Effect>> pairs;
  for (auto i = pool.begin(); i != pool.end(); ++i)
    for (auto k = std::next(i); k != pool.end(); ++k)
      if (!lag_and_delay(*i, *k)) pairs.emplace_back(*i, *k);
  auto alone_n = [&](Effect e) {  // the effect's held-out error alone (round 1)
    for (const auto* s : scored)
      if (s->effect == e) return s->heldout_rmse_after_n;
    return gap_before_n;
  };
  std::map<Effect, double> alone_in_sample;  // each load-transfer pair member's fit alone
  auto alone_in_sample_n = [&](Effect e) {
    if (!alone_in_sample.count(e)) {
      std::vector<Effect> model = base;
      model.push_back(e);
      alone_in_sample[e] = in_sample_rms(fit(pointers(runs), model));
    }
    return alone_in_sample[e];
  };
  std::vector<PairFound> found, found_in_sample;
  std::vector<PairScore> at_range_end;  // listed after the pairs judged
  tried.clear();
  for (const auto& [a, b] : pairs) {
    std::vector<Effect> model = base;
    model.push_back(a);
    model.push_back(b);
    Fit f = fit(pointers(runs), model);
    if (!inside(model, a, f) || !inside(model, b, f)) {
      PairScore s;
      s.rule = PairRule::RangeEnd;
      s.a = score_at(a, model, f);
      s.b = score_at(b, model, f);
      const Effect end = inside(model, a, f) ? b : a;
      const auto j = param_at_bound(model, end, f);
      s.decision =
          j ? fmt::format("{}'s {} at the end of its physical range ({:.4g})", to_string(end),
                          effect_params(end)[*j].name, f.params[*param_offset(model, end) + *j])
            : fmt::format("{} not in the model", to_string(end));
      at_range_end.push_back(std::move(s));
      continue;
    }
    PairFound p;
    p.model = model;
    p.heldout_n = heldout(runs, model, fit);
    p.gain = 1.0 - p.heldout_n / std::max(gap_before_n, 1e-12);
    p.delta_bic = f.bic() - base_fit.bic();
    // Each member's place: the pair against the other member alone.
    p.gain_over_a = 1.0 - p.heldout_n / std::max(alone_n(b), 1e-12);
    p.gain_over_b = 1.0 - p.heldout_n / std::max(alone_n(a), 1e-12);
    p.a = score_at(a, model, f);
    p.b = score_at(b, model, f);
    p.in_sample_n = in_sample_rms(f);
    // Load transfer's pairs also judged in-sample (below): held out, a fold fitted on fewer runs
    // trades the tyre's shape for the load (B's ground pair 3, load transfer with speed friction:
    // fitted on two runs C fell to 0.64 and the third run was missed by 258 N, where the pair
    // fitted to all three hits both within 5 %).
    if (is_load_transfer(a) || is_load_transfer(b)) {
      PairFound q = p;
      q.fit = f;
      q.in_sample = true;
      const double base_n = in_sample_rms(base_fit);
      q.gain = 1.0 - q.in_sample_n / std::max(base_n, 1e-12);
      q.gain_over_a = 1.0 - q.in_sample_n / std::max(alone_in_sample_n(b), 1e-12);
      q.gain_over_b = 1.0 - q.in_sample_n / std::max(alone_in_sample_n(a), 1e-12);
      found_in_sample.push_back(std::move(q));
    }
    p.fit = std::move(f);
    found.push_back(std::move(p));
  }
  // The best pair held out that passes: a pair that explains the gap about as well but has a
  // member that earns no place (its partner alone does nearly as much) does not hide one behind
  // it whose members both do.
  std::stable_sort(found.begin(), found.end(), [](const PairFound& x, const PairFound& y) {
    return x.heldout_n < y.heldout_n;
  });
  std::optional<PairFound> named;
  for (PairFound& p : found) {
    if (named) {
      tried.push_back(pair_score(p, gap_before_n, PairRule::AnotherNamed,
                                 "a pair with less held-out error was named"));
      continue;
    }
    const auto why = refusal(p, gap_before_n, left_n, runs, o);
    tried.push_back(why ? pair_score(p, gap_before_n, why->rule, why->why)
                        : pair_score(p, gap_before_n, PairRule::Named, "named"));
    if (!why) {
      note_alike_members(p, found, gap_before_n, left_n, runs, o);
      named = std::move(p);
    }
  }
  // In-sample, a load-transfer pair must also leave no structure: its in-sample error within
  // the fit-quality factor x the floor (a curve that is not a Magic Formula, reshaped by the
  // load, leaves some).
  if (!named && left_in_sample_n) {
    std::stable_sort(
        found_in_sample.begin(), found_in_sample.end(),
        [](const PairFound& x, const PairFound& y) { return x.in_sample_n < y.in_sample_n; });
    const double floor_n = o.noise_factor * noise_n, base_n = in_sample_rms(base_fit);
    for (PairFound& p : found_in_sample) {
      if (named || p.in_sample_n > floor_n) {
        tried.push_back(pair_score(
            p, base_n, named ? PairRule::AnotherNamed : PairRule::OverFloor,
            named ? "a pair with less in-sample error was named"
                  : fmt::format("leaves {:.1f} N in-sample, over the fit-quality factor x the "
                                "floor ({:.1f} N)",
                                p.in_sample_n, floor_n)));
        continue;
      }
      const auto why = refusal(p, base_n, *left_in_sample_n, runs, o);
      tried.push_back(why ? pair_score(p, base_n, why->rule, why->why)
                          : pair_score(p, base_n, PairRule::Named, "named"));
      if (!why) named = std::move(p);
    }
  }
  for (PairScore& s : at_range_end) tried.push_back(std::move(s));
  return named;
}

}  // namespace brakefit::gap
