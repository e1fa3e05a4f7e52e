#pragma once
// One conditioned run (a brake event) as the gap diagnosis reads it, and how an event becomes one:
// the slip, speeds and force on a common time base, cut at the lock-up runaway and decimated.
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/pipeline/events.hpp"
#include "core/tyre/load_laws.hpp"

namespace brakefit::gap {

struct RunSource;

/// One conditioned run (a brake event), decimated for fitting.
struct Run {
  std::string name;
  can::BenchKind bench = can::BenchKind::Roller;
  double wheel_radius_m = 0.3;
  double brake_gain_n_per_bar = 1.0;
  double wheel_load_n = 0.0;  ///< the station's static wheel load (0: not known)
  std::vector<double> t_s, slip, v_ref_mps, force_n;
  std::vector<double> wheel_accel_mps2;  ///< d v_wheel / dt (negative when the wheel slows)
  /// The encoders' rolled angles (rad) since the run's start: speed / radius integrated (the
  /// wheel's, and the roller's or fifth wheel's), for their once-per-revolution ripple.
  std::vector<double> wheel_angle_rad, ref_angle_rad;
  /// An encoder's once-per-revolution wave as the speeds' smoother passed it into the slip:
  /// smooth(v cos angle) / smooth(v), and the same with sin (empty: cos and sin of the angle).
  /// Sampled slowly, a fast wheel's ripple is mostly smoothed away (at 50 Hz a wheel at 130
  /// km/h turns 0.39 of a revolution between samples, and the five-point smoother passes 0.22
  /// of its ripple, bent in phase); read as the unsmoothed wave it was neither fitted where it
  /// was nor counted in the floor as what was left of it.
  struct Wave {
    std::vector<double> cos, sin;
  };
  std::array<Wave, 2> encoder_wave;    ///< the wheel's, the reference's
  std::vector<double> ref_decel_mps2;  ///< -d v_ref / dt
  std::vector<double> pressure_rate_bar_per_s;
  double noise_n = 0.0;  ///< measurement noise of the force, estimated before decimation
  /// A first-order filter the export declared on its pressure channel (s; 0: none). The model's
  /// force is passed through it (predict), as the transducer's chain passed the true force; the
  /// data are not undone (a derivative of noisy pressure would be noise, and at the ramp's kink
  /// a smeared one).
  double pressure_filter_s = 0.0;
  /// A load transfer declared from the vehicle (Options::declared_load_per_decel_s2_per_m): D by
  /// 1 + q a and B C D by (1 + q a)^r, a the reference's deceleration through a +-20 ms centred
  /// mean, E by load_laws' change, in every fit, as a known part of the tyre's curve (0: none
  /// declared).
  double declared_load_per_decel_s2_per_m = 0.0, declared_kx_load_ratio = 1.0;
  /// The tyre's load laws at which a named load transfer is measured
  /// (Effect::LoadTransferMeasured) and a declared one held: the slip stiffness's load ratio and
  /// E's change with the load; published tyres' unless the tyre's file was given
  /// (Options::tyre_load_laws).
  tyre::LoadLaws load_laws;
  /// The speed channels' noise (robust scale of second differences, at least step/sqrt(12)) and
  /// quantisation steps (0: not quantised), and the force channel's step, before smoothing.
  double v_ref_sd_mps = 0.0, v_wheel_sd_mps = 0.0;
  double v_ref_step_mps = 0.0, v_wheel_step_mps = 0.0, force_step_n = 0.0;
  /// A roller whose drive was seen drooping (its quantised speed stepped with the force): the
  /// speed lost per newton of force behind lag_s (0: not seen). roller_held_quantised: a roller
  /// read through a quantised channel and taken as held (its mean, or its ripple's trend), which
  /// a droop under a step would not show (share_roller_droop).
  double roller_droop_mps_per_n = 0.0, roller_droop_lag_s = 0.0;
  bool roller_held_quantised = false;
  /// A drooping roller's speed as the export read it (the staircase at the run's full rate, before
  /// decimation) with the force it drooped under: the station's runs are fitted again together
  /// (share_roller_droop), one drive behind one lag.
  struct RollerStaircase {
    std::vector<double> t_s, v_mps, force_n;
    double step_mps = 0.0, roller_radius_m = 0.0;
  };
  std::shared_ptr<const RollerStaircase> roller_staircase;
  /// Per point: the standard deviation of the smoothed slip that the speed channels' noise
  /// leaves (errors in variables: through the local slope it is force noise the fit cannot remove).
  std::vector<double> slip_sd;
  /// The run was too short for slip_sd to be measured on it: the floor gives it the measured
  /// runs' speed noise (noise_floor), or, where no run was long enough, the speed noise its
  /// slip at rest shows after the smoother (rest_noise_mps, over rest_slip_steps; NaN: under
  /// 2 steps, or an encoder's ripple left in it), pooled over the runs.
  bool slip_sd_unmeasured = false;
  /// The slip at rest before the brake, for a run whose slip_sd is unmeasured: the lead-in's
  /// samples at rest (NaN where one was not: no step is taken across it), and the encoders'
  /// angles there, rolled back from the run's start, so that an encoder's ripple taken out of
  /// the run is taken out of its rest too (at 50 Hz a fast wheel's ripple reads as noise).
  struct RestProbe {
    std::vector<double> slip, wheel_angle_rad, ref_angle_rad;
    double gain_mps = 0.0;       ///< a sample's slip noise to the speed noise the smoother leaves
    double step_sd_ratio = 0.0;  ///< a sample's slip error the speeds' quantisation leaves
  };
  std::shared_ptr<const RestProbe> rest_probe;
  double rest_noise_mps = NAN;
  std::size_t rest_slip_steps = 0;
  /// What the slip's noise was measured on, at full rate (empty: not measured). An encoder's
  /// ripple taken out of the slip later is taken out of it too and the noise measured again:
  /// a ground wheel's once-per-revolution ripple (4-10 Hz) lies between the two smoothers'
  /// bands and was counted as slip noise that the fitted slip no longer has.
  struct NoiseProbe {
    int half_window = 0;
    std::vector<double> raw_slip, wheel_angle_rad, ref_angle_rad;
    double sd = 0.0;  ///< smoothed_noise_sd of raw_slip
  };
  std::shared_ptr<const NoiseProbe> slip_noise;
  /// The slip and its noise as conditioned, before the encoders' ripple was taken out: each
  /// estimate of the ripple starts from them again (remove_encoder_ripple).
  std::vector<double> slip_as_conditioned, slip_sd_as_conditioned;
  /// The wheel's acceleration and the reference's deceleration as conditioned: the ripple is in
  /// them too, as its derivative (on the ground a fifth wheel's 5e-4 at 10 Hz is 0.6 m/s^2 of
  /// deceleration, which load transfer reads as load).
  std::vector<double> wheel_accel_as_conditioned, ref_decel_as_conditioned;
  /// A fifth wheel's ripple was read from its own speed (or placed there at the other runs'
  /// amplitude) and divided out, with this amplitude: the residual's estimate of the ripple
  /// leaves the reference alone.
  bool ref_ripple_from_speed = false;
  double ref_ripple_amplitude = 0.0;
  double ref_ripple_c = 0.0, ref_ripple_s = 0.0;  ///< its 1 + c cos + s sin of ref_angle_rad
  /// The reference bias taken out when slip_as_conditioned was kept: a later levelling's change
  /// is carried over when an estimate starts from it again.
  double ref_bias_as_conditioned = 0.0;
  /// A constant reference speed read through a quantised channel is off its level by up to half
  /// a step: a slip bias of up to this much, its own in every run (0: not such a channel).
  double ref_bias_bound = 0.0;
  /// The slip while the brake was at rest before the run (the event's lead-in, pressure under
  /// the rest level): the sum of its samples, of their squares, and their count (0: no such
  /// samples). A slip offset reads there as itself (missing_evidence).
  double rest_slip_sum = 0.0, rest_slip_sq_sum = 0.0;
  std::size_t rest_slip_points = 0;
  /// The slip offset held where the wheel rested (NaN: free): a fit's slip offset stays within
  /// foot_pin_tol_ratio of foot_pin_ratio (threshold_at_rest).
  double foot_pin_ratio = NAN, foot_pin_tol_ratio = 0.0;
  double ref_bias_removed = 0.0;  ///< the bias taken out (level_reference_biases)
  /// The bias the levelling wanted before its bound (the intercept's offset), and how that moves
  /// per second of a lag (levelled at the lag, the slip compared with the force is taken
  /// earlier): the lag models (time offset, relaxation at one speed) level at their own lag.
  double ref_bias_wanted = 0.0, ref_bias_per_lag = 0.0;
  /// How the bias the levelling wants moves with a relaxation's length (the contact's slip
  /// compared with the force), at the lengths of the levelling's grid (relaxation_level_change).
  std::vector<double> ref_bias_by_sigma;
  /// A wheel speed quantised and held on one level at the run's start (a roller's wheel rolling
  /// free): the level (m/s) and its step, and when it first left it (s; -inf: not held). The
  /// rebuilt channel follows the first crossings' line back to the level's edge (the wheel read
  /// as slowing 0.1-0.2 s early); the levelling puts the rest where the runs' levels overlap
  /// (the tyre's free-rolling slip is one for all runs: hold_rest_at_foot).
  double held_level_mps = 0.0, held_step_mps = 0.0;
  double held_until_s = -INFINITY;
  bool held_placed = false;  ///< hold_rest_at_foot has placed the rest (once)
  /// The samples a fit takes (empty: all; 0 leaves one out): a two-run set's held-out fold keeps a
  /// block of one run out of the fit while the run's history is still predicted through it.
  std::vector<std::uint8_t> fit_mask;
  bool fitted_at(std::size_t i) const { return fit_mask.empty() || fit_mask[i] != 0; }
  std::size_t fitted_points() const;
  /// Slip rate at the start of the run (least squares over its first 40 ms, full rate): before
  /// the event the slip is taken as the ramp from zero at this rate (time offset).
  double initial_slip_rate_per_s = 0.0;
  /// The line's force at the first sample (line_force_at_start: behind a declared pressure
  /// filter, the ramp the line had made): sets the relaxation's initial transient slip.
  double initial_force_n = 0.0;
  /// The run was cut at a lock-up runaway; the force at its last kept sample.
  bool runaway = false;
  double runaway_force_n = 0.0;
  /// What the run was conditioned from (null for a run built otherwise): a diagnosis conditions
  /// it again with its force channel read later (realign.cpp).
  std::shared_ptr<const RunSource> source;
};

struct ConditionOptions {
  int smooth_half_window = 10;   ///< zero-phase centred moving average of slip and speeds (samples)
  std::size_t max_points = 400;  ///< decimation for fitting
  /// Cut the run at the lock-up runaway: the first slip jump larger than this between two
  /// samples (0: keep everything) and, on the roller, than runaway_slip_per_s over the sample
  /// interval; on the ground than ground_runaway_slip_per_s over it where the jump per sample
  /// alone leaves too few samples for a diagnosis (a 50 Hz export of a fast stop).
  double runaway_slip_per_sample = 0.01;
  double runaway_slip_per_s = 10.0;
  /// On the road a slip rising 4 /s is the wheel losing 33 m/s^2 more than the car at 30 km/h,
  /// 144 at 130: a lock-up at any road speed.
  double ground_runaway_slip_per_s = 4.0;
  pipeline::ForceSource force = pipeline::ForceSource::Pressure;
  /// The force channel read this much later than the speeds (0: as recorded): a channel late by
  /// this shows each moment's force here; the run ends this much before its last sample.
  double channel_advance_s = 0.0;
};

/// A run's event, the calibration and options it was conditioned with.
struct RunSource {
  std::string name;
  pipeline::Event event;
  pipeline::Calibration calibration;
  ConditionOptions options;
};
Run condition(const std::string& name, const pipeline::Event& e, const pipeline::Calibration& c,
              const ConditionOptions& o);
/// Points each of n runs keeps for fitting: ConditionOptions's 400 up to six runs, then a budget
/// of 2 400 points shared (at least 120 a run). Past 20 runs the cost grows with the runs.
std::size_t points_per_run(std::size_t n_runs);
/// The diagnosis's expected time for n runs over its time for three (said before a long run):
/// the fits' points times the held-out folds, against three runs' 1 200 points in three folds.
double relative_cost(std::size_t n_runs);

}  // namespace brakefit::gap
