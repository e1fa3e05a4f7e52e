#pragma once
// The evidence only one effect leaves (evidence.cpp, cradle_cap.cpp), checked before a candidate
// past the gates is named, and the wheel's slip at rest it is read against (conditioning).
#include <cmath>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/gap/gap.hpp"
#include "core/pipeline/samples.hpp"

namespace brakefit::gap {

/// A force cap cuts the curve where it still rises: over the last 15 % of force below the cap
/// (up to 98 % of it for a fitted cap, whose runs go on past it) the force's slope over slip is
/// at least this share of its initial slope (5-30 % of the cap). A tyre's own top, and a curve
/// that is not a Magic Formula (flat-topped), flatten gradually and stay below it.
inline constexpr double kCapKinkFrom = 0.85, kCapKinkTo = 0.98, kCapMinEndSlopeRatio = 0.3;
/// The runs' runaway forces agree within this share of their mean at a cap.
inline constexpr double kCapMaxSpread = 0.03;
/// A cap behind a late channel (rep names a time offset, and no cap): the runs ran away at one
/// force once each is read dt earlier (a late channel reads a fast ramp's runaway lower), and the
/// curve fitted with the offset peaks above it (kCapAtPeakRatio).
std::optional<CapEvidence> cap_behind_lag(const Report& rep, const std::vector<Run>& runs);
/// A cap read from how the runs end, with effects named beside it: the peak of the curve fitted
/// to the whole runs with those effects over the cap (NaN where rep has no such cap). At most
/// kCapAtPeakRatio, the tyre's own peak explains the runaway once the effects are in.
double cap_peak_beside_named(const Report& rep, const std::vector<Run>& runs);
/// The smallest over the runs of that slope ratio at cap_n (NaN where a run has too few points
/// in either band to say).
double cap_kink_ratio(const std::vector<Run>& runs, double cap_n);
/// On the roller a brake threshold holds the wheel at its free-rolling slip while the pressure
/// rises to it: the
/// slip there may move at most this share of what the fitted curve's initial stiffness gives
/// (generators A and B's roller thresholds: -0.1 to 0.15; a Burckhardt curve's steep foot fitted
/// as a threshold on generator C: 0.31-0.45).
inline constexpr double kDeadZoneMaxSlipRatio = 0.25;
/// Why a candidate that passed the gates lacks the evidence only its effect leaves (evidence.cpp):
/// the note (with {} where the round's "after ..." goes) and the score's decision.
struct MissingEvidence {
  std::string note, decision;
  /// The fit is no model of the tyre at all (a threshold whose curve carries no force repeats
  /// the measured force): its gain is no law's bite, and no other candidate is judged by it.
  bool degenerate = false;
};
/// Below this reference speed a sample is not taken (the slip's ratio would blow up).
inline constexpr double kMinRefSpeedMps = 0.3;
/// A lead-in's sample at rest: pressure at most rest_bar, the reference moving, both speeds read.
inline bool at_rest(const pipeline::Sample& s, double rest_bar) {
  return s.pressure_bar <= rest_bar && s.v_ref_mps >= kMinRefSpeedMps &&
         std::isfinite(s.v_wheel_mps);
}
/// Run::rest_slip_*: the slip of the lead-in's samples at rest (at_rest), before the rise the
/// run starts at.
void measure_rest_slip(Run& r, std::span<const pipeline::Sample> lead_in, double rest_bar);
/// The runs' slip at rest pooled: its mean, and its uncertainty: three standard errors and the
/// largest bias a quantised channel leaves (a speed held on one level is off by up to half a
/// step, which the rest does not average out; a held reference's own bound), points.
struct RestSlip {
  double mean = 0, uncertainty = 0;
  std::size_t points = 0;
};
RestSlip pooled_rest_slip(const std::vector<Run>& runs);
/// The slip the model's terms move the curve's foot by (a slip offset, a reference's bias, the
/// tyre's own shift), at the fit's values.
double fitted_foot_ratio(const std::vector<Effect>& model, const Fit& f);
/// A slip offset reads as itself while the wheel rolls free: the slip at rest must carry at least
/// this share of a fitted offset, unless the two agree within the rest slip's uncertainty
/// (generator C's Burckhardt curves and load transfer were fitted with offsets of 5-7e-4 whose
/// runs rested at 0 +- 1e-4; its true offsets, 5e-3 to 2e-2, rested at themselves within 3 %).
inline constexpr double kOffsetMinRestShare = 0.5;
/// On a roller the slip speed is the slip times the roller's speed: speed friction is told from the
/// tyre's curve shape only where the runs' speeds differ by at least this factor (generator C's
/// Burckhardt rollers at one speed were named speed_friction with lambda_mu_v 8-12, a friction
/// falling 20 % at 27 % slip; tyres' 0.8-1.5 move it 3 % at 5 km/h).
inline constexpr double kSpeedFrictionMinSpeedSpread = 1.5;
/// Fewer samples at rest than this over all runs: the offset cannot be checked there.
inline constexpr std::size_t kOffsetMinRestPoints = 10;
/// An effect's magnitude (its first parameter, at index `at` of the fit) within this many of
/// its standard errors of no effect is not named: the fit cannot tell it from zero (generator B's
/// heavy wheel left 1.3x the floor, and load transfer took part of it at -0.001 +- 0.00065 per
/// m/s^2, a load no car's pitch moves). The fit's errors assume independent residuals, so they
/// are, if anything, small: the test errs towards naming.
inline constexpr double kMinMagnitudeZ = 2.0;
/// A brake threshold whose runs rested below the fitted curve's foot: refused where the tyre's
/// force at the rest (at its initial stiffness) is at least this share of the threshold's.
inline constexpr double kThresholdMinRestForceShare = 0.5;
/// A brake threshold whose fitted tyre peaks under this share of the largest force measured is
/// refused: below the threshold the model repeats the measured force (gain min(p, p0)), so a
/// threshold near the runs' top pressure fits any of them with a curve that carries nothing.
/// A threshold that lets the wheel lock leaves the tyre its peak: the measured peak less the
/// threshold's force (B's largest, 30 bar against a 45-75 bar lock, leaves it a third).
inline constexpr double kThresholdMinCurveShare = 0.25;
/// The fastest run's median reference speed over the slowest's (1 without speeds).
double run_speed_spread(const std::vector<Run>& runs);
/// `e` the candidate, the last effect of `model`, fitted as `f`.
std::optional<MissingEvidence> missing_evidence(const EffectScore& e,
                                                const std::vector<Effect>& model, const Fit& f,
                                                const std::vector<Run>& runs);
/// The tyre's own horizontal shift moves the slip it rolls free at with its foot: a free-rolling
/// wheel's brake force is zero. Runs that rested at zero slip (pooled, within its uncertainty)
/// show no shift of the tyre's; a foot `shift_ratio` below that (by more than the uncertainty)
/// reads force while the wheel rolled free: a force channel that reads high from the brake's
/// first moment (a threshold crossed at once), not the tyre. Not refused: a foot above the rest
/// (less force than the slip gives, as a wheel's inertia does while the car slows), and a rest
/// off zero (the tyre's own shift shows there, and a baseline bent by an effect not yet modelled
/// can put its foot elsewhere). The note, or empty.
std::string tyre_shift_contradicted(const std::vector<Run>& runs, double shift_ratio);

}  // namespace brakefit::gap
