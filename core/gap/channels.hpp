#pragma once
// What the diagnosis does to a run's channels, shared by its files: smoothing and the sampler's
// clock, quantised speeds rebuilt, a drooping or held roller, the encoders' ripple, the runs'
// reference biases levelled. Not part of the public interface in gap.hpp.
#include <algorithm>
#include <array>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "core/gap/gap.hpp"

namespace brakefit::gap {

/// Zero-phase Savitzky-Golay smoothing (quadratic, centred; the window shrinks at the ends).
std::vector<double> smooth(const std::vector<double>& x, int half_window);
/// The sampler's clock under the stamps: a tester samples on a regular clock and stamps each
/// sample early or late (jitter, a 1 ms stamp resolution). Where the stamps scatter about one line
/// of the sample index (no drift wider than a quarter interval), that line; otherwise (uneven
/// sampling, a dropped sample) the stamps smoothed as the channels are, made monotone.
/// A sampler's interval read on a run of stamps, and its standard error.
struct SamplerInterval {
  double interval_s = 0, se_s = 0;
};
/// The run's line takes the event's interval where that is the better read (a short stop's 11
/// samples under 5 ms of jitter read a 50 Hz sampler 2.6 % slow, and the declared pressure filter
/// over that clock read a fast stop's force late: a time offset of -0.8 ms took 40 % of a null
/// set's gap), and a whole number of milliseconds within three standard errors of it (a tester's
/// timer ticks in them).
std::vector<double> sampler_clock(const std::vector<double>& stamps_s, int half_window,
                                  std::optional<SamplerInterval> event = std::nullopt);
/// The interval read on every stamp of an event (its lead-in at rest too). nullopt: too few
/// stamps, or not one regular clock.
std::optional<SamplerInterval> sampler_interval(const std::vector<double>& stamps_s,
                                                int half_window);
/// The median of the intervals between successive times (0 for fewer than two).
double median_interval_s(const std::vector<double>& t_s);
/// Central differences (one-sided at the ends).
std::vector<double> derivative(const std::vector<double>& t, const std::vector<double>& x);
/// Linear interpolation of x(t) at `at`, held at the ends.
double interp(const std::vector<double>& t, const std::vector<double>& x, double at);
/// The Magic Formula of a fit's (or parameter vector's) first four: B, C, D, E.
inline MfParams curve_of(const std::vector<double>& params) {
  return MfParams{params[0], params[1], params[2], params[3], 0, 0};
}
/// The line's force at a run's point: the channel with a declared pressure filter (5-20 ms)
/// undone (the line leads the channel by tau times its rate). On a fast ramp the channel reads a
/// bar low: the wheel moves where the line, not the channel, has passed a threshold.
inline double line_force_n(const Run& r, std::size_t i) {
  const bool rate = r.pressure_rate_bar_per_s.size() == r.force_n.size();
  return r.force_n[i] +
         (rate ? r.pressure_filter_s * r.brake_gain_n_per_bar * r.pressure_rate_bar_per_s[i] : 0.0);
}
/// Least-squares line through the samples of the first window_s of a series.
struct StartLine {
  double at_start = 0.0, slope = 0.0;
  int points = 0;
};
StartLine start_line(const std::vector<double>& t_s, const std::vector<double>& x, double window_s);
/// A run's force is read at its start on a line through this much of it: a 250 bar/s ramp adds
/// 170 N in 10 ms, so a mean would sit half of that too high.
constexpr double kStartForceWindowS = 0.02;
/// The line's force at a run's first sample. Without a filter, start_line's. Behind a declared
/// filter (filter_s > 0), the ramp the line makes: its rate read where the channel has settled to
/// it, its onset where the filtered ramp meets the channel's first samples (a ramp begun before
/// the run's start shows in the line, not yet in the channel).
double line_force_at_start(const std::vector<double>& t_s, const std::vector<double>& force_n,
                           double filter_s);
/// The middle of v (of an even count, the upper of the two middles), by partial sorting in place:
/// the robust centre the conditioning's noise, step and speed estimates share. Not empty.
inline double upper_median(std::vector<double>& v) {
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

/// A channel's noise: the robust scale of its second differences, at least step/sqrt(12); step
/// is its quantisation step (0: not quantised).
struct ChannelNoise {
  double sd = 0.0, step = 0.0;
};
ChannelNoise channel_noise(const std::vector<double>& x);
/// A quantised channel rebuilt from its transitions: where the level steps between two samples
/// the signal crossed the middle of the two levels half-way in time; a monotone cubic through those
/// points (each one's slope the parabola's through it and its neighbours), linear beyond them,
/// and never more than half a step from the level read.
std::vector<double> dequantise(const std::vector<double>& t, const std::vector<double>& x,
                               double step);
/// The error a rebuilt channel y keeps from where each transition fell inside its sample
/// interval: |dy/dt| dt / sqrt(12), at most step / sqrt(12), per sample.
std::vector<double> rebuilt_timing_sd(const std::vector<double>& t, const std::vector<double>& y,
                                      double step);
/// A roller held at speed and read through a quantised channel whose levels its encoder's ripple
/// dithers: the smooth speed under the ripple (a quadratic trend fitted with the ripple's two
/// first harmonics to the staircase). Empty when the run is too short to tell them apart.
std::vector<double> held_roller_speed(const std::vector<double>& t_s, const std::vector<double>& v,
                                      double roller_radius_m);
/// A run shorter than this (samples up to the lock or runaway, below a force cap) cannot be
/// smoothed and fitted. A 50 Hz export of a fast ground stop holds 8-11 samples from the pressure's
/// rise to the lock: few, but its linear region and peak, and the runs are fitted pooled.
inline constexpr std::size_t kMinRunSamples = 8;
/// Runs shorter than this are diagnosed, and the report says what they cannot tell alone.
inline constexpr std::size_t kShortRunSamples = 20;
/// A roller's ripple is fitted (held_roller_speed, drooping_roller_speed) when the run spans this
/// many of its turns.
inline constexpr double kHeldRollerMinTurns = 1.0;
/// A roller whose drive droops under the brake's force, read through a quantised channel
/// (roller_droop.cpp): its speed as a level, a droop following the force behind a lag (0-0.4 s), a
/// slow trend and the ripple, fitted to the staircase's transitions. Empty where the staircase
/// does not droop by half a step between its lightest and heaviest fifths of load (a held roller),
/// or the fit misses the transitions.
struct RollerDroop {
  std::vector<double> v_ref_mps;  ///< the rebuilt speed (empty: not a drooping roller)
  double mps_per_n = 0.0;         ///< the speed lost per newton of lagged force (> 0)
  double lag_s = 0.0;
};
RollerDroop drooping_roller_speed(const std::vector<double>& t_s, const std::vector<double>& v,
                                  const std::vector<double>& force_n, double roller_radius_m,
                                  double step_mps);
/// One roller drive droops alike in every run of a station: a run whose droop stayed under half a
/// quantisation step (a short stop, its staircase held on one level) takes the median droop of
/// the runs where it was fitted, its mean speed kept (the slip recomputed). Returns a note, or
/// empty where no run was changed.
std::string share_roller_droop(std::vector<Run>& runs);
/// A drooping drive's misfit at its runs' transitions (steps^2) with the droop refitted at the
/// lag read and at lags 0-0.4 s every 25 ms, and that fit's degrees of freedom (empty where no
/// run droops).
struct DroopLagProfile {
  std::vector<std::pair<double, double>> lag_rss;  ///< lag (s), misfit (steps^2)
  double read_s = 0.0, dof = 1.0, step_s = 0.025;
};
DroopLagProfile droop_lag_profile(const std::vector<Run>& runs);
/// The drooping runs refitted together with the drive's lag held at tau_s, their speeds and
/// slips rebuilt (runs read as held keep the droop they took); false where that fit misses.
bool refit_droop_at(std::vector<Run>& runs, double tau_s);
/// The runs again with the drive's droop refitted at another lag its staircases allow.
struct DroopLagAlternative {
  double lag_s = 0.0;
  std::vector<Run> runs;
};
/// The lags that meet the drooping runs' transitions nearly as well as the one read: their
/// shortest and longest (none where no run droops; droop_lag.cpp). A lag 0.1 s off moves a
/// 2 km/h roller drooping 1.5 mm/s per kN as a channel 16 ms late moves the force: what a named
/// lag must beat.
std::vector<DroopLagAlternative> droop_lag_alternatives(const std::vector<Run>& runs);
/// A fifth wheel's ripple is read from its own speed on runs spanning this many revolutions.
/// Over fewer the trend's misfit (a spline knotted every 0.75 revolutions) projects onto the
/// ripple's columns as much as onto its neighbours': 10 of generator B's 140 ground runs of
/// 1.5-2.5 revolutions read amplitudes 1.7-11x their encoder's (4e-4 for 3.5e-5, load transfer
/// seed 101097), and no test of the fit told them apart. Shorter runs place the others'
/// amplitude (share_fifth_wheel_ripple).
constexpr double kReferenceRippleRevolutions = 2.5;
/// A fifth wheel's once-per-revolution ripple read from its own speed (reference_ripple.cpp).
struct ReferenceRipple {
  bool found = false;
  double amplitude = 0.0;     ///< relative speed ripple
  double revolutions = 0.0;   ///< the fifth wheel's revolutions over the run
  double c = 0.0, s = 0.0;    ///< the ripple divided out: 1 + c cos + s sin of the rolled angle
  std::vector<double> v_mps;  ///< the speed with the ripple divided out (when found)
};
/// Fits the speed as a smooth trend (a cubic spline in the rolled angle, knots 0.75 revolutions
/// apart) times 1 + a once-per-revolution ripple; the ripple is found when significant (3
/// standard errors) and narrow-band (more than the same fit explains at half or twice the
/// rate). Nothing when the run spans fewer than kReferenceRippleRevolutions.
std::optional<ReferenceRipple> fifth_wheel_ripple(const std::vector<double>& t_s,
                                                  const std::vector<double>& v_mps,
                                                  double radius_m);

/// Runs whose fifth wheel's ripple was not found in their own speed (too short to tell it from
/// the trend) take the median amplitude of those that found it and scan its phase on their
/// speed (against the same spline trend); it is taken out of their slip and deceleration. Where
/// it cannot be placed its slip noise carries it (the floor). A run that found its own over
/// few revolutions at an amplitude far from the others' is placed at theirs the same way.
/// Returns a note (empty: none).
std::string share_fifth_wheel_ripple(std::vector<Run>& runs);
/// A once-per-revolution speed ripple: each encoder's speed read as v (1 + c cos + s sin of its
/// rolled angle), for the wheel [0] and the reference [1] where used.
struct SpeedRipple {
  std::array<bool, 2> used{};
  std::array<double, 2> c{}, s{};
};
/// Takes a ripple out of a run's slip, the wheel's acceleration and the reference's deceleration,
/// and out of what its slip noise was measured on (the noise measured again, its slip_sd's
/// measured part replaced). The run's probe stays as it was (AsMeasured: an estimate that starts
/// from the slip as conditioned again) or becomes the probe without the ripple (WithoutRipple:
/// a ripple placed once) (ripple_removal.cpp).
enum class ProbeAfter { AsMeasured, WithoutRipple };
void take_out_ripple(Run& r, const SpeedRipple& ripple, ProbeAfter probe_after);
/// An encoder's unit wave through the speeds' smoother (Run::Wave): smooth(v cos angle) /
/// smooth(v) and the same with sin, for the raw speed v, its smoothed v_smooth and the angle
/// rolled on it (ripple_removal.cpp).
Run::Wave smoothed_wave(const std::vector<double>& v, const std::vector<double>& v_smooth,
                        const std::vector<double>& angle_rad, int half_window);
/// cos and sin of the angle (times frequency_scale): the wave of a speed read before the
/// smoother.
Run::Wave unsmoothed_wave(const std::vector<double>& angle_rad, double frequency_scale = 1.0);
/// Run r's wave for encoder e (0 the wheel, 1 the reference): as its smoother passed it, or cos
/// and sin of its angle where the run carries none.
Run::Wave encoder_wave(const Run& r, std::size_t e);
/// The RMS of a unit ripple of any phase in the wave at point i (1/sqrt 2 unsmoothed): what a
/// ripple left in the slip adds to its noise there.
inline double wave_rms(const Run::Wave& w, std::size_t i) {
  return std::sqrt(0.5 * (w.cos[i] * w.cos[i] + w.sin[i] * w.sin[i]));
}
/// Takes a reference ripple v (1 + c cos + s sin of its angle) out of a run, its probe too: it
/// is placed once, before the encoders' estimates start from the slip as it leaves here.
void take_out_reference_ripple(Run& r, double c, double s);
/// The slip's correction for a ripple at the encoders' angles, (1 - s) (eps_wheel - eps_ref):
/// added to a slip read with the ripple in it.
double ripple_slip_fix(const SpeedRipple& ripple, double slip, double wheel_angle_rad,
                       double ref_angle_rad);

/// Where a run's encoders were at rest before the brake (rest_noise.cpp).
struct RestGeometry {
  double wheel_radius_m = 0.0, ref_radius_m = 0.0;
  double frame_shift_s = 0.0;  ///< speeds that are frame means describe this long before stamp
  double interval_s = 0.0;     ///< the sampler's (0: the stamps')
  double v_wheel_step_mps = 0.0, v_ref_step_mps = 0.0;  ///< the speeds' quantisation steps
};
/// Run::RestProbe from a lead-in's samples up to the run's first (at rest: pressure at most
/// rest_bar, the reference moving); its gain is left to the caller.
Run::RestProbe rest_probe(std::span<const pipeline::Sample> rest, double rest_bar,
                          const RestGeometry& g);
/// The probe with a ripple taken out of its slip.
Run::RestProbe rest_probe_without(const Run::RestProbe& p, const SpeedRipple& ripple);
/// Run::rest_noise_mps and rest_slip_steps from its probe, with the ripple taken out (none: an
/// empty SpeedRipple).
void measure_rest_noise(Run& r, const SpeedRipple& ripple);
/// What the runs' rests say of an encoder's ripple of a relative amplitude read on their
/// residual: each rest fits its own (a level and the encoder's cos and sin); one that could see
/// that amplitude (3 of its standard errors) refutes it when its own lies 3 of them below.
/// Only runs too short to measure their slip noise on keep their rest (Run::rest_probe).
struct RestRippleCheck {
  int judged = 0, refuted = 0;
  double largest_rest_amplitude = 0.0;  ///< over the rests that judged
  double rest_amplitude = 0.0;          ///< their median
  [[nodiscard]] bool refutes() const { return judged > 0 && 2 * refuted > judged; }
};
RestRippleCheck rest_ripple_check(const std::vector<Run>& runs, std::size_t encoder,
                                  double amplitude);
/// An encoder's ripple read on the runs' rests alone, where the slip is flat and no effect bends
/// it. amplitude: the median of the rests that resolve one, when most of them see it (3 of its
/// standard errors); 0 otherwise. phase: per run, the cos and sin coefficients of the speed at
/// that amplitude, where the run's own rest (whose angles run on into the run's) sees it within
/// a factor of 2 of it.
struct RestRipple {
  double amplitude = 0.0;
  std::vector<std::optional<std::array<double, 2>>> phase;
};
RestRipple rest_ripple(const std::vector<Run>& runs, std::size_t encoder);

/// The noise a channel keeps after the smoother (half window), measured on the channel: right
/// for white, anti-correlated and correlated errors alike.
/// Empty when the series is too short to tell noise from signal (4 wide windows).
std::optional<double> smoothed_noise_sd(const std::vector<double>& x, int half_window);
/// White-noise gain of the smoother (the centre Savitzky-Golay weights: sqrt(sum w^2)).
double smoothing_noise_gain(int half_window);

/// Levels the runs' slip biases from a constant quantised reference (Run::ref_bias_bound): the
/// slip at zero force is taken common to all runs. Returns a note for the report (empty: none).
std::string level_reference_biases(std::vector<Run>& runs);
/// The relaxation lengths at which the levelling's change is read (m, the fit's range; the first
/// none): Run::ref_bias_by_sigma holds one entry a length, relaxation_level_change interpolates.
inline constexpr std::array<double, 15> kLevellingSigmaM = {
    0.0, 0.025, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.65, 0.8, 1.0, 1.3, 1.6, 2.0};
/// How far the bias levelled for run r moves when the slip compared with the force is a contact's
/// relaxed over sigma_m (interpolated on the levelling's grid of lengths; 0 where not levelled).
double relaxation_level_change(const Run& r, double sigma_m);

/// Estimates each run's once-per-revolution encoder ripple (wheel and reference, for runs that
/// span 1.5 revolutions) from the residual of the baseline (params, with its nuisance terms)
/// and takes it out of the slip. Returns a note (empty: none found). When none is found the runs
/// keep what the previous estimate left (KeepPrevious), or go back to the slip as conditioned
/// (AsConditioned: a candidate's own estimate must not keep the baseline's).
enum class WhenNoRipple { KeepPrevious, AsConditioned };
std::string remove_encoder_ripple(std::vector<Run>& runs, const std::vector<double>& params,
                                  const std::vector<Effect>& baseline,
                                  WhenNoRipple none = WhenNoRipple::KeepPrevious);

}  // namespace brakefit::gap
