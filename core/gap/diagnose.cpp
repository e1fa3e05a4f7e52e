// The two modes: model vs measurement (diagnose) and bench vs bench (diagnose_transfer).
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "core/gap/gap.hpp"
#include "core/gap/internal.hpp"
#include "core/gap/realign.hpp"
#include "core/gap/warm_fit.hpp"

namespace brakefit::gap {

namespace {

/// Runs of a low-rate export (a fast stop at 50 Hz: 8-11 samples to the lock) are diagnosed with
/// the others; the report says what such a run cannot tell on its own.
std::string short_runs_note(const std::vector<Run>& runs) {
  std::size_t n_short = 0, fewest = SIZE_MAX;
  double widest_s = 0;
  for (const Run& r : runs) {
    if (r.t_s.size() >= kShortRunSamples) continue;
    ++n_short;
    fewest = std::min(fewest, r.t_s.size());
    widest_s =
        std::max(widest_s, (r.t_s.back() - r.t_s.front()) / static_cast<double>(r.t_s.size() - 1));
  }
  if (n_short == 0) return {};
  return fmt::format(
      "{} of {} runs hold fewer than {} samples up to the lock (the fewest {}, {:.0f} ms apart): "
      "each is fitted pooled with the others and checked held out against them; on its own such "
      "a run fixes neither the curve's shape nor a lag or offset shorter than its sample interval",
      n_short, runs.size(), kShortRunSamples, fewest, 1e3 * widest_s);
}

/// The diagnosis; behind_lag: a cap seen behind a lag (cap_behind_lag), each run cut below its
/// own runaway; seek_cap false: no cap is read from how the runs end.
Report diagnose_runs(const std::vector<Run>& runs_in, const MfParams& start, const Options& o,
                     const std::optional<CapEvidence>& behind_lag, bool seek_cap = true) {
  // A force cap (a two-roller cradle): the runs end in a runaway at the cap; the samples from 98 %
  // of the cap on are that runaway, not the tyre, and are left out.
  auto cap = behind_lag ? behind_lag : seek_cap ? cradle_cap_evidence(runs_in) : std::nullopt;
  std::string cap_at_peak;
  if (cap && !behind_lag && cap_at_fitted_peak(*cap, runs_in, start)) {
    cap_at_peak = fmt::format(
        "every run ran away at {:.0f} N (spread {:.1f} %) with its force still rising ({:.0f} % of "
        "the initial slope), as at a cradle's cap, but a Magic Formula fitted to the whole runs "
        "peaks there ({:.3f}x that force): the tyre's own sharp peak (a large negative E) and a "
        "cap at the peak cannot be told apart on these runs, so no cap is named (a cap below the "
        "peak leaves a curve still rising, fitted past it)",
        cap->cap_n, 100 * cap->spread, 100 * cap->end_slope_ratio, cap->fitted_peak_ratio);
    cap.reset();
  }
  const bool declared_load = o.declared_load_per_decel_s2_per_m != 0;
  std::vector<Run> runs;
  for (const Run& r : runs_in) {
    // Behind a lag each run reads the cap at its own runaway force.
    Run cut = cap ? up_to(r, r.force_n, 0.98 * (behind_lag ? r.runaway_force_n : cap->cap_n)) : r;
    cut.load_laws = o.tyre_load_laws;
    if (declared_load) {
      cut.declared_load_per_decel_s2_per_m = o.declared_load_per_decel_s2_per_m;
      cut.declared_kx_load_ratio = o.declared_kx_load_ratio;
    }
    if (cut.t_s.size() >= kMinRunSamples) runs.push_back(std::move(cut));
  }
  if (runs.size() < 2)
    throw InputError(
        fmt::format("gap diagnosis: fewer than two runs with {} samples up to the lock{}",
                    kMinRunSamples, cap ? " and below the force cap" : ""));
  Report rep;
  if (!cap_at_peak.empty()) rep.notes.push_back(cap_at_peak);
  if (declared_load)
    rep.notes.push_back(fmt::format(
        "load transfer declared from the vehicle (D by 1 + {:.4g} per m/s^2 of deceleration, the "
        "slip stiffness by that to the power {:.2f}{}): held in every fit, not a candidate",
        o.declared_load_per_decel_s2_per_m, o.declared_kx_load_ratio,
        o.tyre_load_laws.e_per_peak_scale == 0.0
            ? std::string()
            : fmt::format(", E by {:.3g} per unit of D's change",
                          o.tyre_load_laws.e_per_peak_scale)));
  if (std::string note = share_roller_droop(runs); !note.empty()) rep.notes.push_back(note);
  if (std::string note = short_runs_note(runs); !note.empty()) rep.notes.push_back(note);
  // A constant quantised reference leaves a slip bias common to the runs within half a step: a
  // nuisance term of every fit (the baseline too), not an effect.
  for (const Run& r : runs)
    if (r.ref_bias_bound > 0 && rep.baseline_effects.empty())
      rep.baseline_effects.push_back(Effect::ReferenceBias);
  rep.before = fit_runs(pointers(runs), rep.baseline_effects, start);
  // The tyre's own horizontal shift (MF 6.1 SHx) puts the curve's foot off zero slip: a nuisance
  // slip bias too, when the baseline earns it (each candidate is scored with and without it).
  // Tried on the raw runs and again once the encoders' ripple is out (it can hide the foot).
  std::string shift_refused;  // said once both tries are over (the second may take the shift)
  auto consider_tyre_shift = [&] {
    if (!rep.baseline_effects.empty() && rep.baseline_effects.front() == Effect::TyreShift) return;
    const std::vector<Effect> model{Effect::TyreShift};
    const auto all = pointers(runs);
    const Fit shifted = fit_runs(all, model, start);
    const double drop = rep.before.bic() - shifted.bic();
    if (drop < kTyreShiftBicMargin || !tyre_shift_inside(shifted, model, all)) return;
    const double shift = shifted.params.at(*param_offset(model, Effect::TyreShift));
    if (std::string note = tyre_shift_contradicted(runs, shift); !note.empty()) {
      shift_refused = std::move(note);
      return;
    }
    shift_refused.clear();
    rep.notes.push_back(fmt::format(
        "the curve's foot sits off zero slip (BIC {:.1f} lower with a slip bias common to the runs "
        "of up to {:.1g}): taken as the tyre's own horizontal shift (MF 6.1 SHx), a nuisance term "
        "of the fits, not an effect",
        drop, kTyreShiftBoundRatio));
    rep.baseline_effects = {Effect::TyreShift};
    rep.before = shifted;
  };
  consider_tyre_shift();
  // The instruments' own structure first: the encoders' ripple (from the baseline's residual),
  // then each run's reference bias (levelled at zero force, which the ripple would disturb).
  // (Twice more on the refitted baseline: the first estimate sees the ripple through a
  // baseline it has bent. Each estimate starts from the slip as conditioned.)
  // (A pass that finds nothing leaves the previous one's.)
  // Levelled before as well: a run's own slip bias over a short run would be taken for part
  // of a ripple (its phase placed to cancel 8e-4 of slip, 83 N at the start of a B roller stop).
  if (const std::string shared = share_fifth_wheel_ripple(runs); !shared.empty()) {
    rep.notes.push_back(shared);
    rep.before = fit_runs(pointers(runs), rep.baseline_effects, start);
  }
  if (!level_reference_biases(runs).empty())
    rep.before = fit_runs(pointers(runs), rep.baseline_effects, start);
  std::string ripple = remove_encoder_ripple(runs, rep.before.params, rep.baseline_effects);
  for (int pass = 0; pass < 2 && !ripple.empty(); ++pass) {
    rep.before = fit_runs(pointers(runs), rep.baseline_effects, start);
    std::string again = remove_encoder_ripple(runs, rep.before.params, rep.baseline_effects);
    if (again.empty()) break;
    ripple = std::move(again);
  }
  const std::string levelled = level_reference_biases(runs);
  for (const std::string& note : {ripple, levelled})
    if (!note.empty()) rep.notes.push_back(note);
  if (!ripple.empty() || !levelled.empty()) {
    rep.before = fit_runs(pointers(runs), rep.baseline_effects, start);
    consider_tyre_shift();
  }
  if (!shift_refused.empty()) rep.notes.push_back(shift_refused);
  // Two starts for every fit (three where the model less its last effect was fitted to the same
  // runs: warm_fit.hpp): the baseline (B, C, D, E that absorbed the effect, often the
  // nearest) and a neutral curve from the data (its peak and initial slope, C 1.65, E 0), which
  // the baseline's distortion cannot trap: wheel inertia on the ground pulled the baseline to
  // E 0.92, from where the fit with the effect stopped in a local minimum at 2x the noise.
  const MfParams neutral = neutral_start(runs);
  // The baseline itself from the same starts: fitted from one start it can stop in a local
  // minimum that every candidate's fit (from two) leaves, and then every candidate, whatever
  // its effect, is scored with that minimum's BIC drop (up to 400 on a null set of generator C's
  // ground, which set the BIC gate other data are held to).
  if (Fit refit =
          WarmFitter(curve_of(rep.before.params), neutral)(pointers(runs), rep.baseline_effects);
      refit.ssr < rep.before.ssr)
    rep.before = std::move(refit);
  rep.floor = noise_floor(runs, rep.before.params);
  rep.noise_n = rep.floor.total_n();
  const MfParams base = curve_of(rep.before.params);
  WarmFitter warm(base, neutral);
  const Fitter fit = [&](const std::vector<const Run*>& train, const std::vector<Effect>& e) {
    return warm(train, e);
  };
  rep.gap_before_rmse_n = heldout(runs, rep.baseline_effects, fit);
  rep.where = where_rows(runs, rep.before.params, rep.baseline_effects);

  // A cradle cap exists on a roller only, load transfer on the road only: a vehicle held on the
  // rollers does not pitch, and a roller's deceleration is its drive drooping under the brake's
  // force: a load transfer fitted to it reshapes the curve with the force, which any curve that
  // is not quite a Magic Formula lets it do, on null data too.
  const bool roller = runs.front().bench == can::BenchKind::Roller;
  std::vector<Effect> candidates;
  for (Effect e : kAllEffects)
    if ((e != Effect::CradleCap || roller) && (e != Effect::LoadTransfer || !roller) &&
        !(declared_load && e == Effect::LoadTransfer))
      candidates.push_back(e);
  const char* separability =
      "the data cannot separate {} from {} (held-out gains {:.3f} and {:.3f}); runs at other "
      "speeds or ramp rates would tell them apart";
  select_effects(rep, runs, candidates, fit, o, separability, !cap);
  if (!cap) ripple_against_effects(rep, runs, fit, o, candidates, separability);
  measure_load_transfer(rep, runs, fit, o);
  if (cap) {
    // Found from how the runs end, not fitted: before, the baseline on the whole runs (the
    // runaway at the cap included); after, the baseline on the runs below the cap.
    put_cap_first(rep, cap->cap_n, heldout(runs_in, rep.baseline_effects, fit));
    if (behind_lag)
      rep.notes.push_back(fmt::format(
          "every run ran away at {:.0f} N (spread {:.1f} %) once read behind the named lag, below "
          "the peak of the curve fitted with it ({:.3f}x that force): the force was capped before "
          "the tyre's peak (a two-roller cradle caps it at Fz sin beta); the samples from 98 % of "
          "each run's runaway force on are left out, and B, C, D, E describe the curve only up to "
          "the cap",
          cap->cap_n, 100 * cap->spread, cap->fitted_peak_ratio));
    else
      rep.notes.push_back(fmt::format(
          "every run ran away at {:.0f} N (spread {:.1f} %) while its force was still rising with "
          "slip ({:.0f} % of the initial slope): the force was capped before the tyre's peak (a "
          "two-roller cradle caps it at Fz sin beta); the samples from 98 % of the cap on (the "
          "runaway) are left out, and B, C, D, E describe the curve only up to that force",
          cap->cap_n, 100 * cap->spread, 100 * cap->end_slope_ratio));
  } else if (const auto at = param_offset(rep.accepted, Effect::CradleCap)) {
    rep.cap_n = rep.after.params[*at];
  }
  if (std::find(rep.accepted.begin(), rep.accepted.end(), Effect::LoadTransfer) !=
      rep.accepted.end())
    rep.notes.push_back(
        "on one bench the deceleration follows the braking force, so load transfer reshapes the "
        "curve as a function of slip alone: a tyre whose curve is not a Magic Formula can look "
        "like it (checked here: its stiffness ratio is inside its range); roller runs without "
        "deceleration (--roller/--road) separate the two");
  std::vector<Effect> not_named;
  for (Effect e : candidates)
    if (std::find(rep.accepted.begin(), rep.accepted.end(), e) == rep.accepted.end())
      not_named.push_back(e);
  // Beside the effects named: what an effect must show is what the final model cannot take (a
  // named time offset takes the part of a wheel's inertia that a late channel still shows, and
  // the channel never shows the rest: the wheel's last dt before the runs end). With a cap found
  // from the runaway the final model is of the runs below it: the baseline's is read.
  const bool beside_named = !cap && rep.after.params.size() == param_count(rep.accepted);
  const std::vector<Effect>& reach_model = beside_named ? rep.accepted : rep.baseline_effects;
  rep.reach = effect_reach(runs, beside_named ? rep.after.params : rep.before.params, reach_model,
                           not_named, rep.noise_n, o.gate_gain);
  if (std::string note = reach_note(rep.reach, max_wheel_decel_mps2(runs), reach_model);
      !note.empty())
    rep.notes.push_back(note);
  if (std::string note = borrowed_noise_note(rep.floor); !note.empty()) rep.notes.push_back(note);
  // (With a cap found from the runaway the fits are of the runs below it: no spread is given.)
  if (!cap && std::any_of(rep.accepted.begin(), rep.accepted.end(),
                          [](Effect e) { return !is_nuisance(e); }))
    rep.after_spread = fold_spread(runs, rep.accepted, fit);
  return rep;
}

}  // namespace

namespace {

Report diagnose_checked(const std::vector<Run>& runs_in, const MfParams& start, const Options& o) {
  if (runs_in.size() < 2)
    throw InputError(
        "gap diagnosis needs at least two runs (it checks every effect on a run it was not fitted "
        "to)");
  Report rep = diagnose_runs(runs_in, start, o, std::nullopt);
  // A cap read from how the runs end, beside effects whose curve, fitted with them to the whole
  // runs, peaks at the runaway: the tyre's own sharp peak (a truck's, bent by a threshold or a
  // slip offset when fitted without them) and a cap cannot be told apart. The runs are diagnosed
  // again without a cap, and that is kept where it names the same effects and leaves nothing
  // unexplained.
  if (const double ratio = cap_peak_beside_named(rep, runs_in); ratio <= kCapAtPeakRatio) {
    Report uncapped = diagnose_runs(runs_in, start, o, std::nullopt, false);
    const auto& v = uncapped.verdict;
    if (named_effects(rep.accepted) == named_effects(uncapped.accepted) &&
        std::find(v.begin(), v.end(), "unexplained") == v.end()) {
      uncapped.notes.insert(
          uncapped.notes.begin(),
          fmt::format("every run ran away at {:.0f} N with its force still rising, as at a "
                      "cradle's cap, but the curve fitted to the whole runs with {} peaks there "
                      "({:.3f}x that force): the tyre's own sharp peak and a cap at the peak "
                      "cannot be told apart on these runs, so no cap is named",
                      rep.cap_n, fmt::join(v, ", "), ratio));
      return uncapped;
    }
  }
  // A late channel moves where each run reads its runaway: a cap is looked for again behind the
  // time offset named, and kept where the runs below it name the offset too and leave nothing
  // unexplained.
  if (const auto cap = cap_behind_lag(rep, runs_in)) {
    Report capped = diagnose_runs(runs_in, start, o, cap);
    const auto& v = capped.verdict;
    if (std::find(capped.accepted.begin(), capped.accepted.end(), Effect::TimeOffset) !=
            capped.accepted.end() &&
        std::find(v.begin(), v.end(), "unexplained") == v.end())
      return capped;
  }
  return rep;
}

}  // namespace

Report diagnose(const std::vector<Run>& runs_in, const MfParams& start, const Options& o) {
  Report rep = diagnose_checked(runs_in, start, o);
  if (o.realign_late_channel)
    if (auto aligned = realigned(rep, runs_in, start, o)) return std::move(*aligned);
  return rep;
}

Report diagnose_transfer(const std::vector<Run>& roller, const std::vector<Run>& road_all,
                         const MfParams& start, const Options& o) {
  if (roller.empty()) throw InputError("bench-vs-bench gap: no usable roller run");
  Report rep;
  // The roller's own effects (relaxation, inertia, threshold, a cradle cap...) would bend its B,
  // C, D, E: with two or more roller runs they are diagnosed first (model vs measurement, roller
  // gates) and the corrected parameters are what the roller says about the tyre.
  Fit roller_fit;  // one roller run: the plain fit (no run to check an effect on)
  double cap_n = NAN;
  if (roller.size() < 2) {
    roller_fit = fit_runs(pointers(roller), {}, start);
  } else {
    const Report own = diagnose(roller, start, calibrated_options(Condition::Roller, o));
    roller_fit = own.after;
    cap_n = own.cap_n;
    std::vector<std::string> names;
    for (const auto& v : own.verdict)
      if (v != "none" && v != "unexplained") names.push_back(v);
    if (!names.empty())
      rep.notes.push_back(fmt::format(
          "the roller runs were corrected for their own {} before their B, C, D, E were carried to "
          "the road",
          fmt::join(names, ", ")));
  }
  const bool capped = std::isfinite(cap_n);
  // The roller fit says nothing beyond what the roller runs reached (a roller test stops near
  // the peak, or at the cap): the road runs are compared up to that slip (or force).
  double max_slip = 0;
  for (const Run& r : roller)
    for (double k : r.slip) max_slip = std::max(max_slip, k);
  std::vector<Run> road;
  std::size_t dropped = 0, total = 0;
  for (const Run& r : road_all) {
    Run cut = capped ? up_to(r, r.force_n, cap_n) : up_to(r, r.slip, max_slip);
    total += r.t_s.size();
    dropped += r.t_s.size() - cut.t_s.size();
    if (cut.t_s.size() >= kMinRunSamples) road.push_back(std::move(cut));
  }
  if (road.size() < 2)
    throw InputError(fmt::format(
        "bench-vs-bench gap needs at least two road runs (each transfer effect is checked on a "
        "road run it was not fitted to) with {} samples within the roller runs' reach",
        kMinRunSamples));
  if (dropped > 0)
    rep.notes.push_back(
        capped ? fmt::format("the road runs are compared up to the roller's cap, {:.0f} N ({} of "
                             "{} road samples above it are left out: the roller says nothing "
                             "there)",
                             cap_n, dropped, total)
               : fmt::format("the road runs are compared up to {:.1f} % slip, the largest the "
                             "roller runs reached ({} of {} road samples beyond it are left out: "
                             "the roller fit says nothing there)",
                             100 * max_slip, dropped, total));

  const MfParams base = curve_of(roller_fit.params);
  const Fitter fit = [&](const std::vector<const Run*>& train, const std::vector<Effect>& e) {
    return fit_effects(train, e, base);  // the roller's B, C, D, E held
  };
  rep.before = fit(pointers(road), {});  // the roller's parameters on the road
  rep.floor = noise_floor(road, rep.before.params);
  if (std::string note = borrowed_noise_note(rep.floor); !note.empty()) rep.notes.push_back(note);
  rep.noise_n = rep.floor.total_n();
  rep.before.stderr_.assign(roller_fit.stderr_.begin(), roller_fit.stderr_.begin() + 4);
  rep.gap_before_rmse_n = heldout(road, {}, fit);
  rep.where = where_rows(road, rep.before.params, rep.baseline_effects);
  select_effects(rep, road, {kTransferEffects.begin(), kTransferEffects.end()}, fit, o,
                 "the road runs cannot separate {} from {} (held-out gains {:.3f} and {:.3f})",
                 false);
  if (capped) {
    // The cradle capped the roller below the tyre's peak: the roller curve is known up to the cap
    // only, and the road above it is no gap of the tyre's. Before: the whole road runs against
    // the roller curve; after: the road up to the cap (where the rest was ranked).
    std::vector<Run> whole;
    for (const Run& r : road_all)
      if (r.t_s.size() >= kMinRunSamples) whole.push_back(r);
    const double up_to_cap = rep.gap_before_rmse_n;
    put_cap_first(rep, cap_n, heldout(whole, {}, fit));
    rep.notes.push_back(fmt::format(
        "the cradle capped the roller at {:.0f} N, below the tyre's peak (Fz sin beta): the roller "
        "shows the tyre only up to that force and the road above it is not a gap of the tyre's "
        "({:.1f} N held out on the whole road runs, {:.1f} N up to the cap)",
        cap_n, rep.gap_before_rmse_n, up_to_cap));
  }
  return rep;
}

}  // namespace brakefit::gap
