// A late force channel read at its delay. A run is cut where its wheel runs away (runaway_cut):
// a channel late by dt shows there the tyre dt before, so a large delay leaves each run without
// the last dt of its curve, the peak included on the road, and the curve fitted to what is left
// is not the tyre's: a threshold, an inertia or a slip offset takes the difference past the
// gates beside the offset. Read dt later, the channel shows each moment's force, the run keeps
// its curve up to the runaway, and what the runs show beside the delay is diagnosed on that.
#include "core/gap/realign.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "core/curve.hpp"
#include "core/gap/internal.hpp"

namespace brakefit::gap {

void advance_channel(std::vector<double>& t_s, double advance_s,
                     const std::vector<std::vector<double>*>& channels,
                     const std::vector<std::vector<double>*>& others) {
  const std::size_t n = t_s.size();
  if (n == 0 || !(advance_s > 0)) return;
  std::size_t keep = 0;
  while (keep < n && t_s[keep] + advance_s <= t_s.back()) ++keep;
  // The sample nearest each advanced time, not a mean of the two around it: between two samples
  // a mean halves the channel's noise, from which the floor is read (a generator A set read
  // 1.4x its floor left where 1.1x was, `unexplained`).
  std::vector<std::size_t> from(keep);
  for (std::size_t i = 0, j = 0; i < keep; ++i) {
    const double at = t_s[i] + advance_s;
    while (j + 1 < n && t_s[j + 1] <= at) ++j;
    from[i] = j + 1 < n && t_s[j + 1] - at < at - t_s[j] ? j + 1 : j;
  }
  for (auto* ch : channels) {
    std::vector<double>& x = *ch;
    for (std::size_t i = 0; i < keep; ++i) x[i] = x[from[i]];
    x.resize(keep);
  }
  for (auto* other : others) other->resize(keep);
  t_s.resize(keep);
}

namespace {

/// Readings of the channel at most, and the delay left at which they stop.
constexpr int kRealignReadings = 4;
constexpr double kRealignTolS = 5e-4;

/// The value of e's first parameter in a fit of model, if the model has it.
std::optional<double> first_param(const Fit& f, const std::vector<Effect>& model, Effect e) {
  const auto at = param_offset(model, e);
  if (!at || *at >= f.params.size()) return std::nullopt;
  return f.params[*at];
}

std::vector<std::string> names_of(const std::vector<std::string>& verdict) {
  std::vector<std::string> out;
  for (const auto& v : verdict)
    if (v != "none") out.push_back(v);
  return out;
}

}  // namespace

std::optional<Report> realigned(const Report& rep, const std::vector<Run>& runs,
                                const MfParams& start, const Options& o) {
  const std::vector<Effect> named = named_effects(rep.accepted);
  if (std::find(named.begin(), named.end(), Effect::TimeOffset) == named.end()) return std::nullopt;
  const auto dt = first_param(rep.after, rep.accepted, Effect::TimeOffset);
  if (!dt || *dt < kRealignMinDelayS) return std::nullopt;
  // On the ground only: a roller run ends at its switch-off or a cradle's cap, which a late
  // channel's reading already places (cap_behind_lag reads each runaway dt earlier); read again,
  // generator A's cap beside a 49 ms delay went unnamed and a B delay alone left `unexplained`.
  if (std::any_of(runs.begin(), runs.end(),
                  [](const Run& r) { return !r.source || r.bench != can::BenchKind::Ground; }))
    return std::nullopt;
  // The delay named was fitted to runs without the last dt of their curves: short of the truth
  // by a few ms where the peak was cut (C's 85-100 ms delays: 2-5 ms). Each reading refits the
  // delay left on the realigned runs and reads the channel that much later again, until what is
  // left is under kRealignTolS.
  double advance_s = *dt;
  std::vector<Run> aligned;
  try {
    for (int k = 0; k < kRealignReadings; ++k) {
      aligned.clear();
      for (const Run& r : runs) {
        ConditionOptions co = r.source->options;
        co.channel_advance_s += advance_s;
        aligned.push_back(condition(r.source->name, r.source->event, r.source->calibration, co));
      }
      if (k + 1 == kRealignReadings) break;
      const std::vector<Effect> delay{Effect::TimeOffset};
      const double left =
          first_param(fit_runs(pointers(aligned), delay, start), delay, Effect::TimeOffset)
              .value_or(0.0);
      // Read sample by sample: a residual under half the interval moves no sample.
      if (std::abs(left) < std::max(kRealignTolS, 0.5 * median_interval_s(aligned.front().t_s)))
        break;
      advance_s += left;
    }
  } catch (const InputError&) {  // a run too short once its last dt is read: as it was
    return std::nullopt;
  }
  Options again = o;
  again.realign_late_channel = false;
  Report out;
  try {
    out = diagnose(aligned, start, again);
  } catch (const InputError&) {
    return std::nullopt;
  }
  const std::string before = fmt::format("{}", fmt::join(rep.verdict, ", "));
  const std::string said = fmt::format("{}", fmt::join(out.verdict, ", "));
  // The delay named is dt plus what the realigned runs name of one (a residual, either sign).
  const double residual = first_param(out.after, out.accepted, Effect::TimeOffset).value_or(0.0);
  if (const auto at = param_offset(out.accepted, Effect::TimeOffset)) {
    out.after.params[*at] += advance_s;
  } else {
    out.accepted.push_back(Effect::TimeOffset);
    out.after.params.push_back(advance_s);
    const auto at_before = param_offset(rep.accepted, Effect::TimeOffset);
    out.after.stderr_.push_back(
        at_before && *at_before < rep.after.stderr_.size() ? rep.after.stderr_[*at_before] : NAN);
    if (!out.after_spread.empty()) out.after_spread.push_back(NAN);
  }
  // Every delay the realigned runs were scored at is a residual past advance_s.
  const auto shift = [&](EffectScore& e) {
    if (e.effect == Effect::TimeOffset && !e.params.empty()) e.params.front().second += advance_s;
  };
  for (auto* list : {&out.effects, &out.stopping_round})
    for (auto& e : *list) shift(e);
  for (auto& q : out.pairs_tried) {
    shift(q.a);
    shift(q.b);
  }
  // The offset's own score, as the runs first read it, leads the list (what named it).
  for (const auto& e : rep.effects)
    if (e.accepted && e.effect == Effect::TimeOffset) {
      EffectScore first = e;
      if (!first.params.empty()) first.params.front().second = advance_s + residual;
      out.effects.insert(out.effects.begin(), first);
      break;
    }
  std::vector<std::string> verdict{std::string(to_string(Effect::TimeOffset))};
  for (const auto& v : names_of(out.verdict))
    if (v != verdict.front()) verdict.push_back(v);
  out.verdict = std::move(verdict);
  out.before = rep.before;
  out.baseline_effects = rep.baseline_effects;
  out.gap_before_rmse_n = rep.gap_before_rmse_n;
  out.notes.insert(
      out.notes.begin(),
      fmt::format("time_offset {:.1f} ms named: read that much later, the force channel shows "
                  "each run's curve up to its runaway, which the late channel showed only after "
                  "it (each run is cut there); the runs were conditioned again with the channel "
                  "read {:.1f} ms later (the delay refitted on them until under 0.5 ms is left) "
                  "and diagnosed again: {} (as recorded: {})",
                  1e3 * (advance_s + residual), 1e3 * advance_s, said, before));
  return out;
}

}  // namespace brakefit::gap
