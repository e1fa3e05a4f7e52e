// How the referee scores a trial: the verdict against the injected truth (named first, exactly,
// a pair's two names, an effect outside the catalogue never named) and what the report said of
// it (its scores, estimates, reach).
#include <fmt/format.h>

#include <cctype>
#include <cmath>
#include <string_view>

#include "sim/referee.hpp"
#include "sim/referee_internal.hpp"

namespace brakefit::sim {

bool outside_catalogue(const std::string& effect) {
  return effect == "misspecified" || effect == "pressure_bow" || effect == "friction_fade";
}

bool TrialResult::exact() const {
  if (verdict.empty()) return false;
  if (truth.effect == "none") return verdict == std::vector<std::string>{"none"};
  if (truth.pair())
    return verdict.size() == 2 && ((verdict[0] == truth.effect && verdict[1] == truth.effect2) ||
                                   (verdict[0] == truth.effect2 && verdict[1] == truth.effect));
  return verdict.front() == truth.effect;
}

namespace {

/// The diagnosis said `said` and noted that the data cannot separate it from `effect`: the two
/// names of "cannot separate X from Y" (a note may name a third effect after them, the partner
/// both were fitted beside, which it ties to neither).
bool inseparable(const std::vector<std::string>& notes, const std::string& said,
                 const std::string& effect) {
  static constexpr std::string_view kHead = "cannot separate ", kFrom = " from ";
  const auto name_at = [](const std::string& n, std::size_t at) {
    std::size_t end = at;
    while (end < n.size() && (std::islower(static_cast<unsigned char>(n[end])) || n[end] == '_'))
      ++end;
    return n.substr(at, end - at);
  };
  for (const auto& n : notes) {
    const std::size_t head = n.find(kHead);
    if (head == std::string::npos) continue;
    const std::string x = name_at(n, head + kHead.size());
    if (n.compare(head + kHead.size() + x.size(), kFrom.size(), kFrom) != 0) continue;
    const std::string y = name_at(n, head + kHead.size() + x.size() + kFrom.size());
    if ((x == said && y == effect) || (x == effect && y == said)) return true;
  }
  return false;
}

/// The verdict names no effect: `none` or `unexplained` (they come alone or after the names).
bool names_no_effect(const std::vector<std::string>& verdict) {
  return !verdict.empty() && (verdict.front() == "none" || verdict.front() == "unexplained");
}

}  // namespace

bool TrialResult::correct() const {
  if (exact()) return true;
  if (outside_catalogue(truth.effect))  // never an invented effect
    return names_no_effect(verdict);
  if (verdict.empty() || truth.effect == "none") return false;
  // The name v stands for the effect e: its own, the other lag at one speed, or noted inseparable.
  const auto names = [&](const std::string& v, const std::string& e) {
    return v == e || inseparable(notes, v, e) ||
           (one_speed && detail::is_lag(v) && detail::is_lag(e));
  };
  if (!truth.pair()) return names(verdict.front(), truth.effect);
  // Each effect needs a name of its own: one name that a note ties to both stands for one effect,
  // not two, so the two are matched to distinct names in the verdict.
  for (std::size_t i = 0; i < verdict.size(); ++i)
    for (std::size_t j = 0; j < verdict.size(); ++j)
      if (i != j && names(verdict[i], truth.effect) && names(verdict[j], truth.effect2))
        return true;
  return false;
}

namespace detail {

TrialResult score(const Injection& inj, const gap::Report& rep) {
  TrialResult t;
  t.truth = inj;
  t.verdict = rep.verdict;
  t.notes = rep.notes;
  for (const auto* list : {&rep.effects, &rep.stopping_round})
    for (const auto& e : *list) {
      std::string params;
      for (const auto& [name, value] : e.params) params += fmt::format(" {} {:.4g}", name, value);
      t.scores.push_back(fmt::format("round {} {}{}: gain {:.3f}, dBIC {:.1f}, {}", e.round + 1,
                                     gap::to_string(e.effect), params, e.gain, e.delta_bic,
                                     e.decision));
    }
  for (const auto& q : rep.pairs_tried) {
    t.pairs_tried.push_back({gap::to_string(q.a.effect), gap::to_string(q.b.effect), q.rule});
    std::string params;
    for (const auto* m : {&q.a, &q.b})
      for (const auto& [name, value] : m->params) params += fmt::format(" {} {:.4g}", name, value);
    t.scores.push_back(fmt::format(
        "pair {} + {}{}: {} {:.1f} N (baseline {:.1f} N), gain {:.3f}, each adds {:.3f} and "
        "{:.3f}, dBIC {:.1f}, {}",
        gap::to_string(q.a.effect), gap::to_string(q.b.effect), params,
        q.in_sample ? "in-sample" : "held out", q.rmse_after_n, q.rmse_before_n, q.gain,
        q.gain_over_a, q.gain_over_b, q.delta_bic, q.decision));
  }
  t.estimate = NAN;
  t.estimate2 = NAN;
  for (const auto& e : rep.effects)
    if (e.accepted && e.effect == gap::Effect::LoadTransfer)
      for (const auto& [name, value] : e.params) {
        if (name == "load_ratio_per_decel_s2_per_m") t.load_per_decel_estimate = value;
        if (name == "load_ratio_per_decel_low_s2_per_m") t.load_per_decel_low = value;
        if (name == "load_ratio_per_decel_high_s2_per_m") t.load_per_decel_high = value;
      }
  // The accepted score's when it was named (forward selection appends it after round 1's).
  const auto estimate = [&](const std::string& effect, double& out) {
    bool accepted = false;
    for (const auto& e : rep.effects)
      if (effect == gap::to_string(e.effect) && (e.accepted || !accepted)) {
        out = e.params.front().second;
        accepted = e.accepted;
      }
  };
  estimate(inj.effect, t.estimate);
  if (inj.pair()) estimate(inj.effect2, t.estimate2);
  t.gap_before_n = rep.gap_before_rmse_n;
  const bool named_any = !rep.verdict.empty() && !names_no_effect(rep.verdict);
  for (const auto& r : rep.reach) {
    if (inj.effect == gap::to_string(r.effect) && (inj.pair() || !named_any)) t.reach = r.smallest;
    if (inj.pair() && inj.effect2 == gap::to_string(r.effect)) t.reach2 = r.smallest;
  }
  t.gap_after_n = rep.gap_after_rmse_n;
  t.noise_n = rep.noise_n;
  return t;
}

}  // namespace detail

}  // namespace brakefit::sim
