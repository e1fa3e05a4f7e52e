#pragma once
// Helpers shared by the diagnosis's own files (effects, fits, selection, cradle cap, the two
// modes); not part of the public interface in gap.hpp. The channels' own (smoothing, clocks,
// quantisation, droop, ripple, levelling) are channels.hpp's; the evidence only one effect leaves,
// and the wheel's rest it is read against, evidence.hpp's.
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/gap/channels.hpp"
#include "core/gap/evidence.hpp"
#include "core/gap/gap.hpp"

namespace brakefit::gap {

/// MF 6.1 reference speed V0 (LONGVL), m/s.
inline constexpr double kLongVl = 16.7;
/// The tyre's own horizontal shift (MF 6.1's SHx = PHX1 + PHX2 dfz, a slip of a few 1e-4 at free
/// rolling: TNO 205/60R15 2.2e-4): a nuisance slip bias (Effect::TyreShift) up to this bound when
/// the baseline earns it (its BIC drops by the margin); a fit that names slip_offset takes the
/// whole shift instead.
inline constexpr double kTyreShiftBoundRatio = 5e-4;
inline constexpr double kTyreShiftBicMargin = 10.0;
/// d ln Kx / d ln D at the nominal load of published MF 6.1 car and van tyres, (1 + PKX2/PKX1 +
/// PKX3) / (1 + PDX2/PDX1): the four files sim/second reads give 1.15-1.33 (TNO 205/60R15 1.33,
/// a van's 1.17). The slip stiffness's load sensitivity over the peak's, at which load
/// transfer's magnitude is measured (Effect::LoadTransferMeasured).
inline constexpr double kPublishedKxLoadRatio = tyre::LoadLaws{}.kx_over_peak;
/// How the peak follows the load, d ln D / d ln Fz, of published MF 6.1 tyres: 0.87-0.97 for the
/// four .tir files of sim/second at 0.8-1.15 x their nominal loads. Load transfer's D scale per
/// m/s^2 over it is the load's relative change per m/s^2, dFz/Fz.
inline constexpr double kPublishedPeakLoadExponent = tyre::LoadLaws{}.peak_exponent;
/// The nuisance terms (a slip bias common to the runs), not effects: never named.
inline bool is_nuisance(Effect e) {
  return e == Effect::ReferenceBias || e == Effect::TyreShift;
}
/// The other lag: at one roller speed a relaxation length and a time offset are one observation.
inline std::optional<Effect> lag_twin(Effect e) {
  if (e == Effect::RelaxationLength) return Effect::TimeOffset;
  if (e == Effect::TimeOffset) return Effect::RelaxationLength;
  return std::nullopt;
}
/// Load transfer in any of its forms (free, measured at the published ratio, with E's slope).
inline bool is_load_transfer(Effect e) {
  return e == Effect::LoadTransfer || e == Effect::LoadTransferShape ||
         e == Effect::LoadTransferMeasured;
}
/// Where e's first parameter sits in the params of a fit of model (after B, C, D, E and the
/// effects before it); nothing when the model lacks it.
std::optional<std::size_t> param_offset(const std::vector<Effect>& model, Effect e);
/// e's score as the fit of model holds it: its parameters at the fit's values (the gains and
/// the decision are the caller's).
EffectScore score_at(Effect e, const std::vector<Effect>& model, const Fit& f);
/// The model's effects that are named (its nuisance terms left out), in the model's order.
std::vector<Effect> named_effects(const std::vector<Effect>& model);
/// The slip bias the nuisance terms of a model may take: half a quantisation step of a constant
/// reference, and the tyre's shift when the model carries it (unless slip_offset takes it).
double nuisance_bias_bound(const std::vector<const Run*>& runs, const std::vector<Effect>& model);
/// d predict / d params over the runs' points, stacked run after run (the fits' own central
/// differences).
Eigen::MatrixXd prediction_jacobian(const std::vector<const Run*>& runs,
                                    const std::vector<double>& params,
                                    const std::vector<Effect>& effects);
/// The fit's tyre shift (0 without one) is strictly inside its bound: a foot further off is an
/// effect's (a brake threshold, a slip offset), not the tyre's shift.
bool tyre_shift_inside(const Fit& f, const std::vector<Effect>& model,
                       const std::vector<const Run*>& runs);
/// The model with its tyre shift swapped for the quantisation's bias alone (or dropped).
std::vector<Effect> without_tyre_shift(const std::vector<Effect>& model,
                                       const std::vector<const Run*>& runs);

/// Fits B, C, D, E and the effects to some runs (jointly, or with B, C, D, E held).
using Fitter = std::function<Fit(const std::vector<const Run*>&, const std::vector<Effect>&)>;
/// x at each sample time less dt_s, linear between samples (its first value before the run, its
/// last past it; j walks: t_s rising). A negative dt_s reads later.
std::vector<double> read_earlier(const std::vector<double>& t_s, const std::vector<double>& x,
                                 double dt_s);
/// The transient slip k' of sigma dk'/dx = k - k' along the run's rolled distance, exact for k
/// linear between its points, from y0 (clamped between 0 and k's first value).
std::vector<double> relax(const Run& r, const std::vector<double>& k, double sigma_m, double y0);
/// relax's steps along r at sigma_m: each step's rolled distance over sigma_m, h, then exp(-h)
/// (1 where the wheel stands), 2 n values; and relax over them.
std::vector<double> relax_steps(const Run& r, double sigma_m);
std::vector<double> relax(const std::vector<double>& k, const std::vector<double>& steps,
                          double y0);
/// filter_first_order's decays exp(-dt_i / tau_s) (0 at the first point), and the filter over
/// them.
std::vector<double> filter_decays(const std::vector<double>& t_s, double tau_s);
void filter_first_order(const std::vector<double>& t_s, std::vector<double>& f, double tau_s,
                        double y0, const std::vector<double>& decays);
class PredictCache;
/// predict(), with what depends on the run and one or two parameters alone kept in `cache`
/// across a fit's evaluations (nullptr: computed each time).
std::vector<double> predict(const Run& r, const std::vector<double>& params,
                            const std::vector<Effect>& effects, PredictCache* cache);
/// The reference's deceleration as the wheel's load follows it through the body's pitch:
/// mode_s2 x'' + lag_s x' + x = a, a damped pitch mode of 1 / (2 pi sqrt(mode_s2)) Hz, or with
/// mode_s2 = 0 a first-order lag of lag_s (implicit, stable at any step; both ~ 0: the
/// deceleration itself).
std::vector<double> pitch_lagged_decel(const Run& r, double lag_s, double mode_s2 = 0.0);
/// Held-out folds at most: up to this many runs each is held out alone (leave one run out).
inline constexpr std::size_t kMaxFolds = 6;
/// A two-run set's runs are each held out in this many blocks of consecutive points (heldout).
inline constexpr std::size_t kTwoRunBlocks = 3;
/// Held-out error: RMS over runs of each run's RMSE with parameters fitted on the runs outside its
/// fold (one run per fold up to kMaxFolds runs, blocks of consecutive runs past that; of two runs,
/// each run's kTwoRunBlocks blocks of points, the rest of both runs fitted).
double heldout(const std::vector<Run>& runs, const std::vector<Effect>& effects, const Fitter& fit);
/// The held-out gain over a roller's decelerating samples that names a wheel's inertia whose
/// gain over all samples is diluted (generator B's every-export null sets: up to 0.29).
inline constexpr double kInertiaDecelGain = 0.4;
/// A wheel's inertia on a roller whose held-out gain over all samples is diluted: its evidence
/// where the wheel decelerates (inertia_decel.cpp), in words, or nothing.
std::optional<std::string> inertia_in_deceleration(const std::vector<Run>& runs,
                                                   const std::vector<Effect>& current,
                                                   const std::vector<Effect>& model,
                                                   const EffectScore& s, const Fitter& fit);
/// The held-out error of current and of model on a roller's decelerating samples (nothing where
/// too few decelerate), and model's gain over current there.
struct DecelGain {
  double gain = 0.0, before_n = 0.0, after_n = 0.0;
  std::size_t points = 0;
};
std::optional<DecelGain> gain_where_decelerating(const std::vector<Run>& runs,
                                                 const std::vector<Effect>& current,
                                                 const std::vector<Effect>& model,
                                                 const Fitter& fit);
/// The runs a held-out fold is fitted on: all but fold k's (heldout's folds: one run each up to
/// kMaxFolds runs, blocks of consecutive runs past that); [lo, hi) are the held-out runs.
std::vector<const Run*> fold_training(const std::vector<Run>& runs, std::size_t k, std::size_t& lo,
                                      std::size_t& hi);
/// Fewer held-out folds than this: no spread is given (two fits say little about a spread).
inline constexpr std::size_t kMinSpreadFolds = 3;
/// The parameters' spread between the held-out folds (each fold left out and the model refitted):
/// a delete-a-group jackknife standard error per parameter; empty below kMinSpreadFolds folds
/// (fold_spread.cpp).
std::vector<double> fold_spread(const std::vector<Run>& runs, const std::vector<Effect>& effects,
                                const Fitter& fit);
std::vector<const Run*> pointers(const std::vector<Run>& runs);
/// Where: residual of the 4-parameter model by slip region, by phase, by run.
std::vector<WhereRow> where_rows(const std::vector<Run>& runs, const std::vector<double>& params,
                                 const std::vector<Effect>& baseline);
/// A neutral Magic Formula for the runs: D their peak force, C 1.65, E 0, B from the initial slope.
MfParams neutral_start(const std::vector<Run>& runs);
/// The model with its free load transfer held at the tyre's load laws (LoadTransferMeasured).
std::vector<Effect> at_tyre_load_laws(std::vector<Effect> model);
/// Load transfer, once named, is measured at_tyre_load_laws: its magnitude becomes that fit's, also
/// as dFz/Fz per m/s^2 and, with the vehicle's mass and wheel load, h/L = 2 Fz (dFz/Fz)/m.
void measure_load_transfer(Report& rep, const std::vector<Run>& runs, const Fitter& fit,
                           const Options& o);
/// The smallest magnitude of each one-parameter candidate the runs could show (reach.cpp): its
/// force per unit magnitude beyond what the model's parameters take (their least-squares
/// projection), against the force that would lower a gap of the noise floor alone by the gain
/// gate. Infinite where nothing of it is left beyond the model. `model` is the baseline, or the
/// baseline with the effects named (params: its fit's).
std::vector<EffectReach> effect_reach(const std::vector<Run>& runs,
                                      const std::vector<double>& params,
                                      const std::vector<Effect>& model,
                                      const std::vector<Effect>& candidates, double noise_n,
                                      double gate_gain);
double max_wheel_decel_mps2(const std::vector<Run>& runs);
/// The report's note on what the runs could show beside `model`'s effects (empty where no reach
/// is finite).
std::string reach_note(const std::vector<EffectReach>& reach, double max_decel_mps2,
                       const std::vector<Effect>& model);
/// Where a run is cut (runaway_cut.cpp): the number of its samples kept, up to the wheel's
/// lock-up runaway (the slip jumps by more than ConditionOptions::runaway_slip_per_sample, on the
/// roller and by more than runaway_slip_per_s over the sample interval, on the ground by more than
/// ground_runaway_slip_per_s over it where the jump per sample leaves too few samples; and stays
/// up; on the ground not where the force channel falls with the tyre through it) or a locked wheel.
/// Sets full.runaway and, at a cut, runaway_force_n (the force before the jump). v_wheel: the
/// wheel's speed beside full's reference.
std::size_t runaway_cut(Run& full, const std::vector<double>& v_wheel, can::BenchKind bench,
                        const ConditionOptions& o);
/// A conditioned run decimated uniformly in time to max_points (decimation.cpp): every
/// per-sample series picked at the same samples, the run's scalars kept.
Run decimate(Run full, std::size_t max_points);
/// Forward selection on held-out error, shared by both modes: rep holds the baseline (before,
/// gap_before_rmse_n, noise_n); fills effects, accepted, after, gap_after_rmse_n, verdict, notes.
/// ripple_per_candidate: the largest gains are scored again with the encoders' ripple estimated
/// against their own models; runs become the accepted model's.
void select_effects(Report& rep, std::vector<Run>& runs, const std::vector<Effect>& candidates,
                    const Fitter& fit, const Options& o, const char* separability_note,
                    bool ripple_per_candidate);

/// Once effects are named (ripple_against_effects.cpp): the encoders' ripple estimated again from
/// the residual of their model, the runs levelled again and the model refitted (the gap after,
/// the floor and the named effects' parameters are that refit's). Where the floor so read shows
/// a structured gap the baseline's estimate hid, with at most two named, forward selection runs
/// again on those runs and its report is taken where it leaves no structured gap.
void ripple_against_effects(Report& rep, std::vector<Run>& runs, const Fitter& fit,
                            const Options& o, const std::vector<Effect>& candidates,
                            const char* separability_note);

/// Forward selection's state as its rounds end: the model so far (from the baseline's nuisance
/// terms, never named), its fit and held-out error, and the runs they were scored on. An accepted
/// candidate's own ripple replaces the runs; entry_runs keeps them as round 1 scored them.
struct Selection {
  std::vector<Run>& runs;
  std::optional<std::vector<Run>> entry_runs;
  std::vector<Effect> chosen;
  Fit fit;
  double heldout_n = 0;
  /// The runs as round 1 scored them back in place (where an accepted candidate's replaced them).
  void restore_entry_runs();
  /// The effects named so far, comma-separated.
  std::string named() const;
};
/// The checks on what forward selection named (after_selection.cpp), in order: a lag or delay
/// swapped for its twin, an effect the later ones make needless, a pair neither explains alone, a
/// threshold beside a slip offset fitted below the wheel's rest, the fit-quality and noise-floor
/// vetoes, a parameter the model as named puts at the end of its range, and a fade in an
/// effect's place. Fills rep.accepted, after, gap_after_rmse_n, the joint estimates and the
/// verdict.
void check_selection(Report& rep, Selection& sel, const Fitter& fit, const Options& o);

/// A time offset or relaxation (e, scored on runs against the model `current`) that a drooping
/// roller drive's lag, read at another value its speed's transitions allow, explains within the
/// gain gate: the note and decision saying so (droop_lag.cpp); nothing where it beats them all.
std::optional<MissingEvidence> lag_in_the_drive(const EffectScore& e, const std::vector<Run>& runs,
                                                const std::vector<Effect>& current,
                                                const Fitter& fit, const Options& o);

/// The BIC drop a candidate must reach on runs of `points` fitted points: bic_margin, or
/// bic_margin_per_point x points where that asks more.
double bic_margin_for(const Options& o, std::size_t points);

/// The share of the structure beyond the noise that a held-out error after_n keeps of the one
/// before_n left (noise and structure add in quadrature: sqrt(gap^2 - noise^2)); 1 where nothing
/// beyond the noise was there to explain.
double structure_left_share(double before_n, double after_n, double noise_n);
/// The fit-quality check's "a structured gap is left": after_n above noise_factor x the noise,
/// or above structure_floor_share x that while keeping more than max_structure_left_share of the
/// structure the baseline (before_n) left.
bool structured_gap_left(double before_n, double after_n, double noise_n, const Options& o);

/// The fit-quality check on the first named effect (first_gain: its held-out gain, or the share
/// the named effects explain together) against the largest round-1 gain of any other candidate.
/// law_in_part: the effect's law stands for a family of laws (load transfer's one stiffness
/// ratio for a tyre's own load laws), which a real effect may match only in part.
enum class FitQuality {
  Explained,  ///< no structured gap is left, or the first effect took min_first_gain of the gap
  OneBite,    ///< a gap is left, but the first effect, of such a law, stands out: named
  Nibble,     ///< a gap is left and candidates nibble alike: nothing is named
};
FitQuality fit_quality(double first_gain, double runner_up_gain, double before_n, double after_n,
                       double noise_n, bool law_in_part, const Options& o);

/// Two effects of different laws that take alike small shares of a structured gap: the first
/// named effect's held-out gain (under min_first_gain) and the best other candidate's (rival_gain,
/// not the first's other lag nor load transfer), within separability x the first or more, past
/// the gain gate, where the baseline's gap carries at least as much structure as noise (before_n
/// over sqrt(2) x the floor). A real effect's signature is its own; two laws biting the same part
/// of the curve alike (a threshold's dead zone and an offset's shift at the foot of a brush-model
/// tyre) show a curve that is not a Magic Formula there, however little is left after.
bool nibbled_alike(double first_gain, double rival_gain, double before_n, double noise_n,
                   const Options& o);

/// A parameter at the end of its physical range (a lower end that is physical, a lag of 0, aside).
bool at_bound(double v, const EffectParam& p);
/// A load's pitch mode of 1 / (2 pi sqrt(m)) Hz at this m or more is a body's (5 Hz or slower)...
inline constexpr double kBodyPitchModeMinS2 = 1.0e-3;
/// ...and damped at least this share of critical (lag / (2 sqrt(m))); less is a lag at the end of
/// the range a vehicle's dampers allow.
inline constexpr double kPitchMinDamping = 0.05;
/// The first of effect e's parameters that its fit f (of model) left at the end of its range:
/// its index among effect_params(e) (none: all inside, or e not in the model).
std::optional<std::size_t> param_at_bound(const std::vector<Effect>& model, Effect e, const Fit& f);
/// Where e is a load transfer whose fit f (of model) has a body's pitch mode damped under
/// kPitchMinDamping: its lag's index (the end of the range a vehicle's dampers allow). The
/// selection refuses such a candidate; param_at_bound and named_at_range_end do not ask it.
std::optional<std::size_t> undamped_pitch(const std::vector<Effect>& model, Effect e, const Fit& f);
/// Where model's fit f puts a named effect's parameter at the end of its physical range (the
/// rule the selection names each effect by, held to the model as finally fitted): the note
/// saying so.
std::optional<std::string> named_at_range_end(const std::vector<Effect>& model, const Fit& f);

/// A fit's RMS residual over every point it was fitted to (in-sample).
inline double in_sample_rms(const Fit& f) {
  return std::sqrt(f.ssr / static_cast<double>(std::max<std::size_t>(f.points, 1)));
}

/// Two effects named together that neither explains alone (pair_search.cpp).
struct PairFound {
  std::vector<Effect> model;  ///< the baseline's terms and the two
  Fit fit;
  double heldout_n = 0.0;
  double gain = 0.0;                            ///< over the baseline's held-out gap
  double delta_bic = 0.0;                       ///< against the baseline
  double gain_over_a = 0.0, gain_over_b = 0.0;  ///< the pair against b alone, against a alone
  EffectScore a, b;                             ///< the members, at the pair fit's values
  double in_sample_n = 0.0;                     ///< the pair's RMS residual on all runs
  bool in_sample = false;  ///< judged in-sample (a load-transfer pair): gains are in-sample
  /// "cannot separate" notes: a member another candidate replaces beside the same partner, the
  /// pair still passing and its gain within the separability share.
  std::vector<std::string> notes;
};
/// When forward selection leaves a structured gap (left_n): every pair of round 1's candidates,
/// lag and delay never together, fitted jointly. Of those with both members inside their
/// ranges, the best held out that passes is returned: it explains at least min_first_gain of
/// the baseline's gap, beats what is left by the gain gate, drops the BIC by twice the margin,
/// each member gains the gain gate over the other alone, and each has the evidence only it
/// leaves. Where none passes, pairs with load transfer are judged the same way in-sample
/// (left_in_sample_n: what forward selection left on all runs), when the pair leaves no more than
/// the fit-quality factor x the floor (noise_n) in-sample. Without left_in_sample_n (forward
/// selection named an effect, which held out explains part of the gap) no pair is judged
/// in-sample: a truck's time offset, its residual's rest fitted by load transfer in-sample, was
/// said `load_transfer` first. tried: every pair fitted, in the order judged, and why it was or
/// was not named (Report::pairs_tried).
std::optional<PairFound> search_pairs(const std::vector<Run>& runs, const std::vector<Effect>& base,
                                      const std::vector<EffectScore>& round1, double gap_before_n,
                                      double left_n, const Fit& base_fit, const Fitter& fit,
                                      double noise_n, std::optional<double> left_in_sample_n,
                                      const Options& o, std::vector<PairScore>& tried);

/// A relaxation length or time offset named beside later effects, replaced by its twin
/// (lag_swap.cpp).
struct LagSwap {
  Effect replaced = Effect::TimeOffset;
  std::vector<Effect> model;  ///< the chosen model with the twin in the replaced one's place
  Fit fit;
  double heldout_n = 0.0;
  EffectScore score;  ///< the twin's, accepted
  std::string note;
};
/// Where two or more effects are named, one of them a relaxation length or a time offset, and
/// the runs' speeds are kSpeedFrictionMinSpeedSpread apart or more: the model with its twin in
/// its place, when that leaves less held out, every named effect stays inside its range and the
/// twin has the evidence only it leaves.
std::optional<LagSwap> swap_lag_twin(const std::vector<Run>& runs,
                                     const std::vector<Effect>& chosen, double current_heldout_n,
                                     double gap_before_n, const Fit& base_fit, const Fitter& fit);

/// A named effect the others make needless (needless.cpp).
struct Needless {
  Effect dropped = Effect::TimeOffset;
  std::vector<Effect> model;  ///< the chosen model without it
  Fit fit;
  double heldout_n = 0.0;
  std::string note;
};
/// Where two or more effects are named (none of them load transfer): the model without the one
/// whose removal leaves least held out, when that is less than the chosen model leaves.
std::optional<Needless> needless_effect(const std::vector<Run>& runs,
                                        const std::vector<Effect>& chosen, double current_heldout_n,
                                        const Fitter& fit);

/// Each accepted effect's parameters become the final model's (rep.after): an effect named in
/// round 1 is re-estimated beside those named after it, so a pair's magnitudes are the joint
/// fit's, not the first one's fitted alone.
void take_joint_estimates(Report& rep);

/// The verdict from the accepted effects (nuisance terms unnamed) and the gap left after them:
/// `none` or `unexplained` when none is named, `unexplained` appended when a gap is left.
void name_verdict(Report& rep, const Options& o);

/// The run up to its first sample whose slip (or force) is above the limit.
Run up_to(const Run& r, const std::vector<double>& x, double limit);
/// A cradle cap found on the runs (not fitted) goes first: its held-out gap before is the whole
/// runs' (gap_whole_n), after the gap below the cap (rep's baseline gap so far).
void put_cap_first(Report& rep, double cap_n, double gap_whole_n);

/// A brake threshold beside a named slip offset, told by the wheel's rest (threshold_at_rest).
struct RestThreshold {
  std::vector<Effect> model;  ///< the chosen model and the threshold
  std::vector<Run> runs;      ///< the runs with every fit's offset held at the rest
  Fit fit;                    ///< with the offset held at the rest
  double heldout_n = 0.0;
  EffectScore score;
  std::string note;
};
/// The offset's fitted foot must lie below the rest by more than the rest's uncertainty (three
/// standard errors of its mean and half a quantisation step) and by a slip whose force, at the
/// curve's initial stiffness, is more than a rolling wheel carries there. The rest is a mean over
/// hundreds of samples: the force noise of one point (the floor) bounds no shift of it (a 1.29 bar
/// threshold beside a -0.009 offset rested 83 N, 11 uncertainties, above the fitted foot on a
/// 43 N floor; single offsets of generators A, B and C rest within 0.31 of that drag).
/// The drag of a free-rolling wheel at its rest: rolling resistance, drag and bind
/// (30-45 N on a car's wheel, physics.md: about 1 % of the wheel's load, read here as the curve's
/// peak D) put the rest on the tyre's curve above its foot. A tyre's offset with a lag fitted
/// beside it rests 11 N (0.3 % of D) above its fitted foot, where a 1.3 bar threshold leaves 129 N.
inline constexpr double kRestDragPeakRatio = 0.012;
/// The threshold beside the held offset may leave this much more held out than the offset alone
/// (the two fit one line; holding the offset costs a little).
inline constexpr double kRestThresholdHeldoutSlack = 0.05;
/// Where a named slip offset (no threshold named) was fitted below where the wheel rested, by a
/// slip whose force stands above the noise: the chosen model and a brake threshold fitted with the
/// offset held at the rest (RestThreshold::runs), when the threshold is inside its range, has the
/// evidence a threshold leaves and leaves about as little held out. The runs are not changed.
std::optional<RestThreshold> threshold_at_rest(const std::vector<Run>& runs,
                                               const std::vector<Effect>& chosen,
                                               const Fit& current, double current_heldout_n,
                                               double noise_n, const Fitter& fit);

/// The energy the contact slid so far at each sample of the run, kJ: |F| |slip| V integrated
/// over time from the run's own channels (fade_rival.cpp).
std::vector<double> slid_energy_kj(const Run& r);

/// For each effect the chosen model names (not load transfer): the fade (a friction fading with
/// the energy slid, outside the catalogue) fitted in its place; for the first where it leaves
/// under half of what the chosen model leaves (held out; in-sample beside load transfer), or,
/// beside load transfer where held out the model does no better than the baseline
/// (gap_before_n), less with the fade taking at least 1 % of the friction, the note saying so:
/// the runs then follow the energy slid, and nothing is named.
std::optional<std::string> fade_rival(const std::vector<Run>& runs,
                                      const std::vector<Effect>& chosen, const Fit& current,
                                      double current_heldout_n, double gap_before_n,
                                      const Fitter& fit);

}  // namespace brakefit::gap
