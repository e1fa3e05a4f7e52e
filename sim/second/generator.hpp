#pragma once
// The second physics (generator B), written apart from sim/simulator.*: MF 6.1 tyres read from
// .tir files (or a brush-model tyre), an adaptive-step RK4 wheel and vehicle integrator, the other
// brakes of the vehicle working on the ground, load transfer through MF 6.1's load laws, and a
// tester's export: speeds quantised, pressure filtered and quantised, jittered time stamps on a
// coarse clock, encoder eccentricity (once-per-revolution ripple), a leading stationary part,
// and events that end just short of the detector's thresholds (the tester switches off on its
// own filtered slip). Its output is the event CSV text a tester's software would export.
#include <cstdint>
#include <string>
#include <vector>

#include "core/can/layout.hpp"
#include "core/rng.hpp"
#include "sim/second/tyre.hpp"

namespace brakefit::sim2 {

/// What a tester's software does to the signals before it exports them.
struct TesterExport {
  double sample_hz = 1000;
  double jitter_ratio = 0.2;         ///< stamp jitter, sigma as a fraction of the interval
  double stamp_resolution_s = 1e-3;  ///< stamps are rounded to this clock (repeats happen)
  double speed_step_mps = 0.001;     ///< speeds quantised to this step (0.5-3 mm/s)
  double pressure_filter_s = 0.01;   ///< first-order filter on the pressure channel
  double pressure_step_bar = 0.01;
  double pressure_noise_bar = 0.03;
  double eccentricity_ref = 2e-4, eccentricity_wheel = 2e-4;  ///< relative speed ripple
  double slip_filter_s = 0.05;  ///< the tester's own slip filter for its switch-off
  double switch_off_slip = 0.27, lock_slip = 0.94;
  double leading_s = 0.3;  ///< rolling before the pedal
  /// The pressure transducer's non-linearity (outside the gap catalogue): a bow through zero and
  /// full scale (the run's max_pressure_bar), its largest deviation, at mid-range, this fraction
  /// of full scale: p + 4 a p_fs (p / p_fs) (1 - p / p_fs). 0: a linear transducer.
  double pressure_bow_ratio = 0;
};

/// One brake run of generator B.
struct RunCase {
  can::BenchKind bench = can::BenchKind::Roller;
  Mf61Longitudinal tyre;
  bool brush = false;  ///< a brush-model tyre (not a Magic Formula) around the MF tyre
  BrushTyre brush_tyre;
  double fz_n = 4000, pressure_pa = 2.2e5;
  double speed_kmh = 5, ramp_bar_per_s = 25, max_pressure_bar = 150;
  double radius_m = 0.3, inertia_kgm2 = 0.2, brake_gain_nm_per_bar = 20, threshold_bar = 0;
  // effects
  double relaxation_m = 0, time_offset_s = 0, radius_error_ratio = 0, lmuv = 0;
  /// Friction fading with the energy slid (outside the gap catalogue): the tyre's force scaled by
  /// 1 / (1 + fade d), d the energy slid per unit of load over the run, the integral of
  /// F v_slip / Fz dt (m; a tread heating as it slides). 0: no fade.
  double fade_per_m = 0;
  // the vehicle (ground)
  double mass_kg = 1500, load_per_decel = 0;  ///< relative load change per m/s^2 (0: none)
  /// The body's pitch: the load follows the deceleration through a first-order lag of
  /// pitch_lag_s, or, where pitch_hz > 0, through a damped pitch mode (a second-order low-pass of
  /// that natural frequency and damping ratio, unit gain: it overshoots a step for damping < 1).
  double pitch_lag_s = 0;
  double pitch_hz = 0, pitch_damping = 0.5;
  /// The roller's drive slows under the brake's load (its motor's slip): the roller speed settles
  /// at V0 (1 - droop F / droop_ref) behind a first-order lag (0: a stiff drive).
  double roller_droop_ratio = 0, roller_droop_ref_n = 1, roller_droop_tau_s = 0.2;
  double other_brakes_ratio = 2.0;  ///< the other wheels' brake force / this wheel's, per bar
  double other_mu = 1.0;            ///< the other wheels' friction limit (x their load)
  TesterExport tester;
  std::uint64_t seed = 1;
};

/// Simulates the run and returns the tester's export as an event CSV (the `brakefit export`
/// format; the header carries what a station knows: bench, radii, load, gain, pressure, speed).
std::string simulate_event_csv(const RunCase& c);

/// The tyres of sim/second/tyres/*.tir, parsed (read from the source tree): cars and vans.
const std::vector<Mf61Longitudinal>& tyre_library();
/// The heavy-vehicle tyres of sim/second/tyres/heavy/*.tir (loads to 40 kN, E down to -8).
const std::vector<Mf61Longitudinal>& heavy_tyre_library();

/// Which stations a set is drawn from. Cars: a car or van on a 5 km/h roller (three pedal ramps)
/// or at 30, 50 and 70 km/h on the ground, exported at 500 or 1000 Hz. Every: the exports
/// stations make: 50-1000 Hz, 2-6 runs a set, rollers at 2-6 km/h whose drive droops under the
/// brake's load, a heavy vehicle in a quarter of the sets (a truck tyre at 18-40 kN, air brakes
/// to 8 bar, 2-3 km/h on the roller), ground runs spread over 30-130 km/h (trucks to 90).
enum class Stations { Cars, Every };

/// A set of three runs of one tyre, vehicle and effect, as the referee draws it. effect: a gap
/// effect name, "none", "misspecified" or one outside the catalogue ("pressure_bow": the
/// transducer's bow as a fraction of full scale; "friction_fade": the fade per m of energy slid
/// per unit load); magnitude in the diagnosis parameter's unit (for
/// load_transfer it is overwritten with the D scale per m/s^2 of the drawn vehicle and tyre).
struct SetDraw {
  std::vector<RunCase> runs;
  std::string station;             ///< what was drawn: vehicle, runs, export rate, roller speed
  double magnitude = 0;            ///< the first effect's
  std::vector<double> magnitudes;  ///< each effect's, in the order given
};
SetDraw draw_set(can::BenchKind bench, const std::string& effect, double magnitude,
                 std::uint64_t seed, Stations stations = Stations::Cars);
/// Several effects in one set (the referee's pairs); the tyre, vehicle and export are drawn as
/// for one effect of the same seed. A heavy vehicle's brake threshold and wheel inertia are
/// scaled to it (the threshold by its air brakes' 8 bar against 160, the inertia by R^2 Fz) and
/// the truth in magnitudes says so.
struct EffectDraw {
  std::string effect;
  double magnitude = 0;
  /// Load transfer only: by default the vehicle drawn for the set (its h/L) sets it and the
  /// magnitude is not read; given, the magnitude is the peak's scale per m/s^2 of deceleration
  /// (dFz/Fz per m/s^2 times the tyre's d ln D / d ln Fz), as a detection curve asks for.
  bool load_given = false;
};
SetDraw draw_set(can::BenchKind bench, const std::vector<EffectDraw>& effects, std::uint64_t seed,
                 Stations stations = Stations::Cars);

}  // namespace brakefit::sim2
