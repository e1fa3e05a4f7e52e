// Ranking and forward selection: one effect a round on held-out error past the gates, each
// candidate inside its range (and the effects named before it inside theirs), beyond the
// nuisance terms' slip and with the evidence only it leaves; separability notes; the leading
// candidates scored with the encoders' ripple seen through their own model. (The checks on what
// it named are after_selection.cpp's; the gates, gates.cpp's; the held-out error, heldout.cpp's.)
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <optional>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"

namespace brakefit::gap {

/// A candidate's own ripple estimate (own_ripple) is made for the kOwnRippleCandidates largest
/// gains of a round that reach kOwnRippleGateShare x the gain gate: a ripple read through the
/// baseline takes part of an effect the baseline cannot bend to (generator B's load transfer,
/// its load up 70 %: ratio at its bound, 0.47 of the gap; 0.83 against its own ripple), and a
/// candidate far below the gate has nothing the ripple could have taken. Two passes, as the
/// baseline's.
constexpr std::size_t kOwnRippleCandidates = 2;
constexpr double kOwnRippleGateShare = 0.5;
constexpr int kOwnRipplePasses = 2;

/// The effect's parameters (the last of the fit's) all inside their physical ranges.
static bool params_inside(Effect e, const Fit& f) {
  const auto eps = effect_params(e);
  for (std::size_t j = 0; j < eps.size(); ++j)
    if (at_bound(f.params[f.params.size() - eps.size() + j], eps[j])) return false;
  return true;
}

/// The encoders' ripple estimated against a candidate's model instead of the baseline: from the
/// slip as conditioned, refitted and estimated again (as the baseline's is), each run's
/// reference bias levelled again. Empty when the runs carry no ripple estimate to redo.
static std::vector<Run> own_ripple(const std::vector<Run>& runs, const std::vector<Effect>& model,
                                   const Fit& start_fit, const Fitter& fit) {
  if (std::none_of(runs.begin(), runs.end(),
                   [](const Run& r) { return !r.slip_as_conditioned.empty(); }))
    return {};
  std::vector<Run> own = runs;
  Fit f = start_fit;
  for (int pass = 0; pass < kOwnRipplePasses; ++pass) {
    if (pass > 0) f = fit(pointers(own), model);
    remove_encoder_ripple(own, f.params, model, WhenNoRipple::AsConditioned);
    level_reference_biases(own);
  }
  return own;
}

/// Forward selection on held-out error, shared by both modes: rep holds the baseline (before,
/// gap_before_rmse_n, noise_n); fills effects, accepted, after, gap_after_rmse_n, verdict, notes.
void select_effects(Report& rep, std::vector<Run>& runs, const std::vector<Effect>& candidates,
                    const Fitter& fit, const Options& o, const char* separability_note,
                    bool ripple_per_candidate) {
  std::vector<const Run*> all = pointers(runs);
  // The slip the nuisance terms account for: half a step of a constant quantised reference, and
  // the tyre's own shift when the baseline carries it.
  const double resolution = nuisance_bias_bound(all, rep.baseline_effects);
  // The baseline's nuisance terms stay in every model (but the tyre's shift, which each
  // candidate may do without); they are not named.
  const std::vector<Effect>& base = rep.baseline_effects;
  Selection sel{runs, {}, base, rep.before, rep.gap_before_rmse_n};
  std::vector<Effect>& chosen = sel.chosen;
  Fit& current_fit = sel.fit;
  double& current_heldout = sel.heldout_n;
  std::optional<std::vector<Run>>& entry_runs = sel.entry_runs;
  std::map<Effect, EffectScore> latest;  // each candidate's score in the last round it was scored
  rep.stopping_round.clear();
  rep.pairs_tried.clear();
  for (std::size_t round = 0; round < o.max_effects; ++round) {
    std::vector<EffectScore> scores;
    std::vector<Fit> fits;
    std::vector<std::vector<Effect>> models;
    std::vector<std::optional<std::string>> decel;  // a wheel's inertia where the wheel decelerates
    // The current model without the tyre's shift, held out: a candidate fitted without the shift
    // is credited with what it adds to that model too, not with the shift's own removal (a
    // two-run null set of B's gained 16 % with an inertia, a threshold and a cap all at zero).
    std::optional<double> plain_current;
    auto plain_current_heldout = [&] {
      if (!plain_current) {
        const std::vector<Effect> p = without_tyre_shift(chosen, all);
        plain_current = p == chosen ? current_heldout : heldout(runs, p, fit);
      }
      return *plain_current;
    };
    for (Effect e : candidates) {
      if (std::find(chosen.begin(), chosen.end(), e) != chosen.end()) continue;
      std::vector<Effect> model = chosen;
      model.push_back(e);
      EffectScore s;
      s.effect = e;
      s.heldout_rmse_before_n = current_heldout;
      s.heldout_rmse_after_n = heldout(runs, model, fit);
      if (e == Effect::LoadTransfer) {
        // Also held out with the stiffness's load ratio and E held at the tyre's laws, the model
        // it is measured at once named: on a few runs the free ratio, fitted per fold, trades
        // the tyre's shape for the load and spends what the held-out run would have shown.
        s.heldout_rmse_after_n =
            std::min(s.heldout_rmse_after_n, heldout(runs, at_tyre_load_laws(model), fit));
      }
      Fit f = fit(all, model);
      // With the tyre's shift and without it: an effect the baseline bent to the shift (load
      // transfer's reshaped curve) may need none. The variant with its parameters inside their
      // ranges is the candidate's, then the one with the lower held-out error.
      if (const auto plain = without_tyre_shift(model, all); plain != model) {
        const double e_plain = heldout(runs, plain, fit);
        Fit f_plain = fit(all, plain);
        const bool in = params_inside(e, f) && tyre_shift_inside(f, model, all),
                   in_plain = params_inside(e, f_plain);
        if (in_plain != in ? in_plain : e_plain < s.heldout_rmse_after_n) {
          s.heldout_rmse_after_n = e_plain;
          s.heldout_rmse_before_n = std::min(current_heldout, plain_current_heldout());
          model = plain;
          f = std::move(f_plain);
        }
      }
      s.gain = 1.0 - s.heldout_rmse_after_n / std::max(s.heldout_rmse_before_n, 1e-12);
      s.delta_bic = f.bic() - current_fit.bic();
      s.params = score_at(e, model, f).params;
      decel.push_back(inertia_in_deceleration(runs, chosen, model, s, fit));
      scores.push_back(s);
      fits.push_back(std::move(f));
      models.push_back(std::move(model));
    }
    if (scores.empty()) break;
    auto by_gain = [&] {  // the scores' indices, largest gain first
      std::vector<std::size_t> order(scores.size());
      std::iota(order.begin(), order.end(), 0);
      std::sort(order.begin(), order.end(),
                [&](std::size_t a, std::size_t b) { return scores[a].gain > scores[b].gain; });
      return order;
    };
    // The largest gains scored again with the encoders' ripple estimated against their own
    // models (own_ripple); kept where that lowers the held-out error.
    std::vector<std::vector<Run>> own_runs(scores.size());
    std::vector<double> through_baseline(scores.size(), NAN);  // held-out, the baseline's ripple
    if (ripple_per_candidate) {
      // The current model's held-out error with its ripple estimated the same way: a candidate
      // is credited with what it adds to that estimate, not with the estimate's own change (a
      // null set of generator B's gained 12 % with a 0.2 ms time offset, the re-estimated ripple
      // taking as much with no offset at all).
      struct Reference {
        double heldout_n, bic;
      };
      std::optional<Reference> reference;
      auto own_reference = [&] {
        if (!reference) {
          reference = Reference{current_heldout, current_fit.bic()};
          if (const std::vector<Run> own = own_ripple(runs, chosen, current_fit, fit); !own.empty())
            if (const double e = heldout(own, chosen, fit); e < current_heldout)
              reference = Reference{e, fit(pointers(own), chosen).bic()};
        }
        return *reference;
      };
      const std::vector<std::size_t> leading = by_gain();
      for (std::size_t k = 0; k < std::min(kOwnRippleCandidates, leading.size()); ++k) {
        const std::size_t i = leading[k];
        if (scores[i].gain < kOwnRippleGateShare * o.gate_gain) break;
        std::vector<Run> own = own_ripple(runs, models[i], fits[i], fit);
        if (own.empty()) break;
        const double e_own = heldout(own, models[i], fit);
        if (e_own >= scores[i].heldout_rmse_after_n) continue;
        Fit f = fit(pointers(own), models[i]);
        EffectScore& sc = scores[i];
        through_baseline[i] = sc.heldout_rmse_after_n;
        sc.heldout_rmse_after_n = e_own;
        const Reference ref = own_reference();
        sc.heldout_rmse_before_n = ref.heldout_n;
        sc.gain = 1.0 - e_own / std::max(ref.heldout_n, 1e-12);
        sc.delta_bic = f.bic() - ref.bic;
        sc.params = score_at(sc.effect, models[i], f).params;
        fits[i] = std::move(f);
        own_runs[i] = std::move(own);
      }
    }
    std::size_t points = 0;
    for (const Run& r : runs) points += r.fitted_points();
    const double margin = bic_margin_for(o, points);
    auto past_gates = [&](const EffectScore& e) {
      return e.gain >= o.gate_gain && e.delta_bic <= -margin;
    };
    // A wheel's inertia shown where the wheel decelerates passes with its diluted gain.
    auto passes = [&](std::size_t i) { return past_gates(scores[i]) || decel[i].has_value(); };
    // The candidates that pass first, each group by gain.
    std::vector<std::size_t> order = by_gain();
    std::stable_partition(order.begin(), order.end(), passes);
    // The best candidate past the gates whose parameters all lie inside their physical ranges (a
    // misspecified curve on the ground was taken for load transfer with the stiffness ratio at
    // its end, 3); one at the end of a range is noted and the next one is considered.
    for (std::size_t i = 0; i < scores.size(); ++i) {
      EffectScore& e = scores[i];
      e.round = static_cast<int>(round);
      if (passes(i)) continue;
      if (e.gain < o.gate_gain)
        e.decision = fmt::format("held-out gain below the gate {:.3f}", o.gate_gain);
      else if (e.delta_bic > -margin)
        e.decision = fmt::format("BIC drop below the margin {:.1f}", margin);
    }
    std::size_t pick = order.size();
    for (std::size_t k = 0; k < order.size() && pick == order.size(); ++k) {
      EffectScore& e = scores[order[k]];
      if (!passes(order[k])) break;  // the passing first: the rest do not pass the gates either
      const auto eps = effect_params(e.effect);
      std::optional<std::size_t> end;
      for (std::size_t j = 0; j < eps.size() && !end; ++j)
        if (at_bound(e.params[j].second, eps[j])) end = j;
      bool undamped = false;
      if (!end) {
        end = undamped_pitch(models[order[k]], e.effect, fits[order[k]]);
        undamped = end.has_value();
      }
      bool inside = !end.has_value();
      if (end) {
        const double v = e.params[*end].second;
        const char* why = undamped ? ", a body's pitch mode undamped" : "";
        rep.notes.push_back(fmt::format(
            "{}{} would explain part of the residual only with {} at the end of its physical "
            "range ({:.4g}{}): not accepted",
            to_string(e.effect),
            round == 0 ? "" : fmt::format(" (round {}, after {})", round + 1, sel.named()),
            eps[*end].name, v, why));
        e.decision =
            fmt::format("{} at the end of its physical range ({:.4g}{})", eps[*end].name, v, why);
      }
      // The effects named before it, refitted beside it, stay inside their ranges too: a joint
      // fit that pushes one of them to its end (load transfer's stiffness ratio to 0 beside a
      // threshold, where a time offset was the cause) trades that effect's law for the new one.
      const std::vector<Effect>& model = models[order[k]];
      for (Effect prior : model) {
        if (!inside || prior == e.effect || is_nuisance(prior)) continue;
        const auto j = param_at_bound(model, prior, fits[order[k]]);
        if (!j) continue;
        inside = false;
        const char* name = effect_params(prior)[*j].name;
        const double v = fits[order[k]].params.at(*param_offset(model, prior) + *j);
        rep.notes.push_back(fmt::format(
            "{} (round {}, after {}) would explain part of the residual only with {}'s {} at the "
            "end of its physical range ({:.4g}): not accepted",
            to_string(e.effect), round + 1, sel.named(), to_string(prior), name, v));
        e.decision = fmt::format("{}'s {} at the end of its physical range ({:.4g})",
                                 to_string(prior), name, v);
      }
      // A slip offset no larger than the nuisance terms take (half a quantisation step of a
      // constant reference, and the tyre's own shift when the baseline carries it) is that
      // resolution, not an effect.
      if (inside && e.effect == Effect::SlipOffset && std::abs(e.params[0].second) <= resolution) {
        inside = false;
        rep.notes.push_back(fmt::format(
            "slip_offset {:.2g} is within the slip the nuisance terms account for ({:.2g}: half a "
            "quantisation step of the reference{}): not accepted",
            e.params[0].second, resolution,
            std::find(base.begin(), base.end(), Effect::TyreShift) != base.end()
                ? ", and the tyre's own shift"
                : ""));
        e.decision = fmt::format("within the nuisance terms' slip ({:.2g})", resolution);
      }
      // The evidence only the effect leaves (a cap's kink, a dead zone's free-rolling wheel):
      // without it a curve that is not a Magic Formula fits alike (generator C's Burckhardt
      // tyres were named cradle_cap in 28 of 30 roller sets).
      if (inside) {
        auto missing = missing_evidence(e, models[order[k]], fits[order[k]], runs);
        if (!missing) missing = lag_in_the_drive(e, runs, chosen, fit, o);
        if (missing) {
          inside = false;
          rep.notes.push_back(fmt::format(fmt::runtime(missing->note),
                                          round == 0 ? "" : fmt::format(" after {}", sel.named())));
          e.decision = missing->decision;
          e.degenerate = missing->degenerate;
        }
      }
      if (inside) pick = k;
    }
    if (pick < order.size()) {
      const Effect taken = scores[order[pick]].effect;
      scores[order[pick]].decision =
          round == 0 ? "accepted (round 1: the largest gain past the gates)"
                     : fmt::format("accepted (round {}: the largest further gain)", round + 1);
      if (const auto& d = decel[order[pick]]; d && !past_gates(scores[order[pick]])) {
        scores[order[pick]].decision = fmt::format("accepted (round {}: {})", round + 1, *d);
        rep.notes.push_back(fmt::format("{} (round {}): {}", to_string(taken), round + 1, *d));
      }
      for (auto& e : scores)
        if (e.decision.empty())
          e.decision =
              fmt::format("passed the gates, but {} gained more in this round{}", to_string(taken),
                          round == 0 ? " (forward selection re-scores the rest below)" : "");
    } else {
      for (auto& e : scores)
        if (e.decision.empty())
          e.decision =
              "passed the gates, but a candidate with more gain failed them: none was "
              "taken in this round";
    }
    if (pick < order.size()) {
      EffectScore& best = scores[order[pick]];
      best.accepted = true;
      for (std::size_t k = pick + 1; k < order.size(); ++k) {
        const EffectScore& next = scores[order[k]];
        if (passes(order[k]) && best.gain - next.gain < o.separability * best.gain)
          rep.notes.push_back(fmt::format(fmt::runtime(separability_note), to_string(best.effect),
                                          to_string(next.effect), best.gain, next.gain));
        break;
      }
    }
    if (round == 0) rep.effects = scores;
    for (const auto& e : scores) latest[e.effect] = e;
    if (pick == order.size()) {
      if (round > 0) rep.stopping_round = scores;
      break;
    }
    const EffectScore& best = scores[order[pick]];
    if (round > 0) rep.effects.push_back(best);
    chosen = models[order[pick]];
    if (!own_runs[order[pick]].empty()) {  // the accepted model's ripple is the runs' from now on
      if (!entry_runs) entry_runs = std::move(runs);
      runs = std::move(own_runs[order[pick]]);
      all = pointers(runs);
      rep.notes.push_back(fmt::format(
          "{} was scored with the encoders' ripple estimated against its own model: held-out "
          "{:.1f} N ({:.1f} N through the baseline's estimate of the ripple, which took part of "
          "its bend)",
          to_string(best.effect), best.heldout_rmse_after_n, through_baseline[order[pick]]));
    }
    current_heldout = best.heldout_rmse_after_n;
    current_fit = fits[order[pick]];
  }
  // A candidate that passed alone but lost round 1 says what became of it later.
  for (auto& e : rep.effects) {
    if (e.round != 0 || e.decision.rfind("passed the gates, but", 0) != 0) continue;
    const auto it = latest.find(e.effect);
    if (it == latest.end() || it->second.round == 0) continue;
    const EffectScore& l = it->second;
    e.decision = fmt::format(
        "passed the gates alone; in round {}, after the effects before it, "
        "gain {:.3f}, dBIC {:.1f}: {}",
        l.round + 1, l.gain, l.delta_bic, l.decision);
  }
  check_selection(rep, sel, fit, o);
}

}  // namespace brakefit::gap
