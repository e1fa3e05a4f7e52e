#pragma once
// Sim-to-real gap diagnosis (model vs measurement): where the 4-parameter formula and the measured
// runs disagree, which unmodelled effect explains it, and how far the gap shrinks on withheld runs.
// Each candidate effect is the equation of shared/docs/physics.md §3 added to the Magic Formula,
// fitted jointly with B, C, D, E over all runs; candidates are ranked by leave-one-run-out error
// and accepted only past a gain gate and a BIC margin.
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/gap/run.hpp"
#include "core/magic_formula.hpp"
#include "core/pipeline/events.hpp"

namespace brakefit::gap {

enum class Effect {
  RelaxationLength,
  TimeOffset,
  WheelInertia,
  BrakeThreshold,
  SlipOffset,
  LoadTransfer,
  SpeedFriction,
  RollerFriction,  ///< bench vs bench only: road/roller friction ratio scales D
  /// Bench vs bench only: load transfer against the roller's held curve, where its effect on the
  /// curve's shape (E) is identifiable too (with B, C, D, E free, E absorbs it). Named
  /// "load_transfer" like LoadTransfer.
  LoadTransferShape,
  /// Not a candidate: load transfer refitted, once named, with the slip stiffness's load ratio
  /// held at the published tyres' (kPublishedKxLoadRatio) for its magnitude. Runs that end just
  /// past the peak fix q x ratio (how the stiffness grows with load) much better than q (how the
  /// peak does); the free ratio still decides whether it is named. Named "load_transfer".
  LoadTransferMeasured,
  /// Bench vs bench only, found on the roller runs (not fitted): the two-roller cradle capped the
  /// braking force (Fz sin beta), so the roller never showed the tyre above cap_n.
  CradleCap,
  /// Not a candidate: a nuisance in every fit when the reference speed was constant and
  /// quantised (a slip bias common to the runs, within half a quantisation step).
  ReferenceBias,
  /// Not a candidate: a nuisance in every fit when the baseline earns it, in place of
  /// ReferenceBias: the tyre's own horizontal shift (MF 6.1 SHx, a slip of a few 1e-4) and the
  /// quantisation's bias, one slip bias common to the runs.
  TyreShift,
  /// Not a candidate and never named: each named effect's rival, a friction fading with the
  /// energy the tyre slid so far in the run (outside the catalogue; fade_rival.cpp). Where it
  /// explains the runs better in an effect's place, nothing is named.
  FrictionFade
};
inline constexpr std::array<Effect, 8> kAllEffects = {
    Effect::RelaxationLength, Effect::TimeOffset,   Effect::WheelInertia,  Effect::BrakeThreshold,
    Effect::SlipOffset,       Effect::LoadTransfer, Effect::SpeedFriction, Effect::CradleCap};
/// The transfer effects of bench-vs-bench mode (roller fit -> road runs).
inline constexpr std::array<Effect, 6> kTransferEffects = {
    Effect::RollerFriction,   Effect::LoadTransferShape, Effect::SpeedFriction,
    Effect::RelaxationLength, Effect::TimeOffset,        Effect::WheelInertia};
const char* to_string(Effect e);

/// Where the runs come from: model vs measurement on a roller bench (5 km/h) or on flat ground
/// (40 km/h, fifth wheel), or roller vs road (bench vs bench). The acceptance gates are
/// calibrated on null data of each condition.
enum class Condition { Roller, Ground, RollerToRoad };
const char* to_string(Condition c);

struct EffectParam {
  const char* name;  ///< SI name, e.g. "sigma_m"
  double lo, hi, start;
  /// The lower end is a value the physics takes (a load that follows the deceleration without a
  /// lag), not the edge of what the data can say: a fit ending there is not refused for it.
  bool lo_is_physical = false;
};
EffectParam effect_param(Effect e);  ///< the first parameter: the effect's magnitude
/// All parameters of an effect (load transfer has two: its magnitude and the stiffness ratio).
std::span<const EffectParam> effect_params(Effect e);
std::size_t param_count(const std::vector<Effect>& effects);  ///< 4 + the effects' parameters
/// B, C, D, E and the effects' parameter names, in the order of Fit::params.
std::vector<std::string> param_names(const std::vector<Effect>& effects);

/// A first-order filter (time constant tau_s) over f in place, exact for f linear between the
/// points t_s, from the state y0 at the first point.
void filter_first_order(const std::vector<double>& t_s, std::vector<double>& f, double tau_s,
                        double y0);
/// Predicted measured force for parameters {B, C, D, E, then each effect's parameters}.
std::vector<double> predict(const Run& r, const std::vector<double>& params,
                            const std::vector<Effect>& effects);

struct Fit {
  std::vector<double> params;  ///< B, C, D, E, then the effects' parameters (param_names)
  std::vector<double> stderr_;
  double ssr = 0.0;
  std::size_t points = 0;
  double bic() const;
  /// The curve's initial slip stiffness, B C D (N per unit slip).
  double slip_stiffness_n() const { return params[0] * params[1] * params[2]; }
};
Fit fit_runs(const std::vector<const Run*>& runs, const std::vector<Effect>& effects,
             const MfParams& start);
double rmse(const Run& r, const std::vector<double>& params, const std::vector<Effect>& effects);

struct Options {
  double gate_gain = 0.10;   ///< minimum held-out gain (1 - after/before) to accept an effect
  double bic_margin = 10.0;  ///< minimum BIC decrease
  /// Minimum BIC decrease per point fitted (0: none), where it asks more than bic_margin. What a
  /// null set's structure lets a candidate take is a share of each point's error, so its BIC
  /// drop grows with the points fitted: a set of 2 000 points at 1 000 Hz and one of 300 at
  /// 50 Hz are held to the same drop per point, not the same drop (bic_margin_for).
  double bic_margin_per_point = 0.0;
  double noise_factor = 1.5;  ///< held-out RMSE above noise_factor x noise = a gap is left
  /// The vehicle's mass where it is known (0: not): load transfer is also given as the centre of
  /// gravity's height over the wheelbase.
  double vehicle_mass_kg = 0.0;
  /// A ground test's load transfer declared from the vehicle's geometry (declared_load_transfer:
  /// the peak's q per m/s^2 and the slip stiffness's load ratio; 0: none): held in every fit, the
  /// baseline's too, and not a candidate. Unheld, its change of the curve with the deceleration
  /// is shared out among the instrument's effects (a wheel's inertia, a threshold) it resembles.
  double declared_load_per_decel_s2_per_m = 0.0, declared_kx_load_ratio = 1.0;
  /// The tyre's own load laws at the runs' wheel load, where its MF 6.1 file is known
  /// (tyre::load_laws_at; the source names the file), else published tyres' (empty source): a
  /// named load transfer's magnitude is measured and read at them (load_transfer_report.cpp).
  tyre::LoadLaws tyre_load_laws;
  std::string tyre_load_laws_source;
  std::size_t max_effects = 3;  ///< forward selection depth
  /// A time offset named of kRealignMinDelayS or more on the ground: the runs conditioned again
  /// with the force channel read that much later and diagnosed again (realign.cpp; needs each
  /// run's source).
  bool realign_late_channel = false;
  /// When a gap above noise_factor x noise is left, the first accepted effect must have had at
  /// least this held-out gain, else none is named (fit-quality check: a curve that is not a Magic
  /// Formula makes every candidate nibble at the residual; a real effect takes a large bite).
  double min_first_gain = 0.4;
  /// Below noise_factor x the floor a structured gap is still left where the held-out error lies
  /// above structure_floor_share x noise_factor x the floor (with the shipped factor 1.5: 1.2 x,
  /// above every null set measured, generator A's at 0.91-1.11, C's at 0.83-1.05) and keeps more
  /// than max_structure_left_share of the structure beyond the noise, sqrt(gap^2 - floor^2),
  /// that the baseline left.
  double structure_floor_share = 0.8;
  double max_structure_left_share = 0.5;
  /// Load transfer under min_first_gain is still named where its round-1 gain is at least this x
  /// every other candidate's (one bite, not several nibbling alike: generator C's Burckhardt
  /// curves gave their best candidates 1.04-1.25x the runner-up's gain).
  double min_bite_over_runner_up = 3.0;
  /// An effect is named only where the baseline's held-out gap exceeds this x the noise floor: a
  /// baseline that already fits within the noise leaves nothing for an effect to explain. Below
  /// 1: the floor is an estimate, known to about 10 % (generator A's null sets, whose noise is
  /// white, sit at 0.91-1.11 x their floor on the ground, 0.94-1.08 on the roller).
  double min_gap_over_floor = 0.9;
  double separability =
      0.15;  ///< two candidates whose gains differ less than this are "not separable"
};

/// The runs' median wheel load (the bench calibration's wheel_load_n), N; 0 where none carries
/// one. Load transfer is put relative to it.
double median_wheel_load_n(const std::vector<Run>& runs);

struct EffectScore {
  Effect effect{};
  std::vector<std::pair<std::string, double>> params;
  double heldout_rmse_before_n = 0.0;
  double heldout_rmse_after_n = 0.0;
  double gain = 0.0;
  double delta_bic = 0.0;
  bool accepted = false;
  /// 0: the effect alone against the baseline (every candidate); k > 0: the one forward
  /// selection added in its round k+1, scored against the model chosen before it.
  int round = 0;
  std::string decision;  ///< why it was or was not accepted, in words
  /// Its fit is no model of the tyre (evidence.cpp: a threshold whose curve carries no force):
  /// its gain is left out of the runner-up, the rival and the pairs.
  bool degenerate = false;
};

/// The rule that decided a pair of the pair search: named, or the first it failed (the share of
/// the gap a pair must explain, the gain gate over what selection left, twice the BIC margin, a
/// member that adds under the gain gate over the other alone, the evidence only a member leaves,
/// a member on its range's end, in-sample over the fit-quality factor x the floor), or another
/// pair named before it was judged.
enum class PairRule {
  Named,
  ShareOfGap,
  GainOverSelection,
  BicMargin,
  MemberGain,
  Evidence,
  RangeEnd,
  OverFloor,
  AnotherNamed
};
const char* to_string(PairRule r);

/// Two candidates fitted together by the pair search (pair_search.cpp), and why the pair was or
/// was not named.
struct PairScore {
  EffectScore a, b;  ///< the members at the pair fit's values, the one that adds more first
  /// The baseline's error and the pair's: held out, or in-sample where in_sample.
  double rmse_before_n = NAN, rmse_after_n = NAN;
  double gain = NAN;         ///< 1 - after / before
  double gain_over_a = NAN;  ///< the pair against b alone: what a adds beside b
  double gain_over_b = NAN;
  double delta_bic = NAN;  ///< against the baseline
  bool in_sample = false;  ///< a load-transfer pair judged in-sample
  bool accepted = false;   ///< rule == PairRule::Named
  PairRule rule = PairRule::Named;
  std::string decision;  ///< the rule in words, with the figures that decided it
};

struct WhereRow {
  std::string region;
  double rms_residual_n = 0.0;
  double share = 0.0;  ///< of the total squared residual
};

/// The noise floor of runs for a curve: the force channel's noise and the slip noise carried
/// through the curve's local slope (errors in variables), RMS over the points.
struct Floor {
  double force_n = 0.0;  ///< force channel
  double slip_n = 0.0;   ///< slip noise x |dF/dslip| of the curve
  double total_n() const { return std::hypot(force_n, slip_n); }
  double slip_sd_ratio = 0.0;                       ///< RMS slip noise (after smoothing)
  double v_ref_sd_mps = 0.0, v_wheel_sd_mps = 0.0;  ///< RMS over runs
  double v_ref_step_mps = 0.0, v_wheel_step_mps = 0.0, force_step_n = 0.0;  ///< largest
  /// Runs too short to measure their slip noise on, and the measured runs' speed noise they
  /// took at their own speed (0: none borrowed).
  int borrowed_runs = 0;
  double borrowed_speed_noise_mps = 0.0;
  bool pooled_noise = false;  ///< no run long enough: measured on the runs' slip at rest
};
Floor noise_floor(const std::vector<Run>& runs, const std::vector<double>& params);
/// The report's note on the runs that borrowed their slip noise (empty: none did).
std::string borrowed_noise_note(const Floor& fl);

/// The smallest magnitude of an effect a set's runs could show (Report::reach).
struct EffectReach {
  Effect effect{};
  double smallest = INFINITY;  ///< in the effect's parameter's unit (effect_param)
};

struct Report {
  std::vector<std::string> verdict;
  std::vector<EffectScore> effects;  ///< first round: every candidate alone on the baseline
  /// Where forward selection stopped after choosing an effect: the round that took none, each
  /// candidate scored beside the effects chosen and why it was not taken (empty where round 1
  /// took none, or where selection stopped at its depth). The checks after selection (a veto, a
  /// pair in its place) leave it as selection ran; the notes say what they changed. What a
  /// `..., unexplained` verdict's reader asks first: what the rest did once the first was in.
  std::vector<EffectScore> stopping_round;
  /// Where the pair search ran (a structured gap left with at most two effects named): the
  /// pairs of round 1's candidates fitted together, in the order they were judged (least error
  /// first), each with why it was or was not named. What a reader asks of a second effect that
  /// was expected and not named.
  std::vector<PairScore> pairs_tried;
  std::vector<Effect> accepted;  ///< the baseline's nuisances first, then the named effects
  /// Terms in every fit, the baseline too (ReferenceBias), not effects: before.params has theirs.
  std::vector<Effect> baseline_effects;
  std::vector<WhereRow> where;
  double gap_before_rmse_n = 0.0;  ///< held-out (leave one run out)
  double gap_after_rmse_n = 0.0;
  double noise_n = 0.0;  ///< the floor: force noise and slip noise through the slope (floor)
  Floor floor;
  Fit before, after;
  /// after.params' spread between the runs: each held-out fold left out and the model refitted,
  /// a jackknife standard error per parameter (empty with fewer than three runs). The bench
  /// model's standard errors take it where it exceeds the fit's own (after.stderr_).
  std::vector<double> after_spread;
  std::vector<std::string> notes;
  /// A force cap found on the runs (roller cradle): from the runaway at one force, or the fitted
  /// cradle_cap effect; NaN when none.
  double cap_n = NAN;
  /// Model vs measurement: for each one-parameter candidate not named, the smallest magnitude
  /// (in its parameter's unit) these runs could have shown beside the effects named (infinite:
  /// none).
  std::vector<EffectReach> reach;
};

/// A force cap on the roller (the cradle's Fz sin beta): every run ran away at one force (within
/// 3 %) while its force was still rising with slip (the slope over its last 15 % of force at
/// least 0.3x the initial slope; a tyre runs away at its peak, where the slope is zero).
struct CapEvidence {
  double cap_n = 0.0;            ///< mean runaway force
  double spread = 0.0;           ///< (max - min) / mean of the runaway forces
  double end_slope_ratio = 0.0;  ///< smallest end / initial slope over the runs
  /// The peak (D) of a Magic Formula fitted to the whole runs, over the cap: a cap below the tyre's
  /// peak cuts a curve still rising, which the fit carries on past it (generator A's cradles:
  /// 1.06-1.22); a tyre that ran away at its own sharp peak puts D there (a truck tyre with E
  /// down to -7: 0.996-1.013).
  double fitted_peak_ratio = NAN;
};
std::optional<CapEvidence> cradle_cap_evidence(const std::vector<Run>& runs);
/// A Magic Formula fitted to the whole runs peaks within this of the runaway force: the runs
/// ended at the tyre's own peak or at a cap no lower than it, which the runs cannot tell apart.
inline constexpr double kCapAtPeakRatio = 1.03;
/// Sets e.fitted_peak_ratio from fits of the whole runs (from start), as they are and from the
/// wheel's rest where they rested off zero slip (the lower); true where it is at most
/// kCapAtPeakRatio.
bool cap_at_fitted_peak(CapEvidence& e, const std::vector<Run>& runs, const MfParams& start);

/// The gates calibrated on null data of the condition by bench/gap_referee --calibrate (the
/// figures are in docs/gap.md); the other options as in base.
Options calibrated_options(Condition c, Options base = {});

/// Needs at least two runs (leave-one-run-out). Throws InputError otherwise.
Report diagnose(const std::vector<Run>& runs, const MfParams& start, const Options& o = {});

/// Only the effects' parameters, with B, C, D, E held at base (bench-vs-bench mode).
Fit fit_effects(const std::vector<const Run*>& runs, const std::vector<Effect>& effects,
                const MfParams& base);

/// Bench vs bench: B, C, D, E fitted on the roller runs predict each road run from its measured
/// slip; each transfer effect is then fitted on the road runs (B, C, D, E held) and ranked by
/// leave-one-road-run-out error; forward selection as in diagnose(). Needs two road runs.
Report diagnose_transfer(const std::vector<Run>& roller, const std::vector<Run>& road,
                         const MfParams& start, const Options& o = {});

}  // namespace brakefit::gap
