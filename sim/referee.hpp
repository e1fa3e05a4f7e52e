#pragma once
// The blinded-injection referee of the gap diagnosis: draw an effect (or none) and a magnitude,
// simulate a set of runs at three pedal ramp rates, hide the label, diagnose, score. Three
// conditions: model vs measurement on the roller (5 km/h) and on flat ground (40 km/h), and roller
// vs road (the transfer effects). Also the gate calibration on null data (seeds disjoint from the
// referee's), per condition.
#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "core/gap/gap.hpp"
#include "core/rng.hpp"
#include "sim/scenario.hpp"
#include "sim/second/generator.hpp"

namespace brakefit::sim {

/// The null of every referee condition: every effect off, a wheel inertia whose signature stays
/// below the force noise (0.005 kg m^2), pressure noise 0.05 bar, ideal encoders.
Scenario referee_null(can::BenchKind bench);

/// Which physics makes the runs: A, the project's simulator (sim/simulator.*, candump logs), or
/// B, the second physics written apart (sim/second: .tir tyres, a brush family, its own
/// integrator, a tester's event-CSV export read back through the event CSV parser), or C, a
/// physics written outside the project (its runs come from outside_runs, which the referee sets:
/// the project's own code holds none of it).
enum class Generator { A, B, C };
const char* to_string(Generator g);

struct Injection {
  std::string effect = "none";  ///< gap effect name, "none" or outside_catalogue's
  double magnitude = 0.0;       ///< in the diagnosis parameter's unit (sigma_m, p0_bar, ...)
  gap::Condition condition = gap::Condition::Roller;
  Generator generator = Generator::A;  ///< B: roller and ground conditions only
  /// A second effect injected with the first (a pair; roller and ground, C's on the ground), ""
  /// for none.
  std::string effect2 = {};
  double magnitude2 = 0.0;
  bool pair() const { return !effect2.empty(); }
  /// Load transfer's truth as the wheel load's relative change per m/s^2 of deceleration
  /// (dFz/Fz), set where the runs are made (NaN: no load transfer).
  double load_per_decel = NAN;
  /// The simulated tyre's load laws at the set's wheel load (what its MF 6.1 file gives), set
  /// where the runs are made: the diagnosis is given them where the tyre's file is taken as known
  /// (set_tyre_file_known).
  tyre::LoadLaws tyre_laws = {};
  /// Generator B's load transfer at this magnitude (a detection curve's), not its vehicle's own.
  bool load_given = false;
  /// What generator B drew for the set (vehicle, runs, export rate, speeds); empty for A and C.
  std::string station = {};
  /// The load transfer injected (first or second), its magnitude in the diagnosis's unit; NaN:
  /// none.
  double load_transfer_magnitude() const;
};

/// The effects the referee draws in a condition (besides none) and their magnitude ranges.
const std::vector<std::string>& referee_effects(gap::Condition c, Generator g = Generator::A);
Injection draw_injection(Rng& rng, double p_none, gap::Condition c = gap::Condition::Roller,
                         Generator g = Generator::A);
/// The range an effect's magnitude is drawn from (lo, hi of its size; either sign is drawn where
/// the effect has one). Throws InputError for an effect the condition does not draw.
std::pair<double, double> effect_range(gap::Condition c, Generator g, const std::string& effect);
/// Two different effects of the condition, each in its range. Lag and delay are not drawn
/// together: at one speed they are one effect (the referee's runs of a set share a speed).
/// Generator C: two effects whose ranges overlap, at one magnitude drawn in the overlap (its
/// script gives a set one magnitude); InputError where it has no such two (its roller).
Injection draw_pair(Rng& rng, gap::Condition c, Generator g = Generator::A);
/// Whether draw_pair draws pairs of generator g in condition c.
bool draws_pairs(gap::Condition c, Generator g);
/// Generator B: three runs (roller: three pedal ramps; ground: 30, 50, 70 km/h) exported as event
/// CSVs, read back through parse_event_csv and the pipeline, conditioned. The injection's
/// magnitude is set to the drawn truth where the vehicle decides it (load transfer).
/// An event CSV's text read back through the parser and the pipeline, its fittable events
/// conditioned (an event too short to condition is skipped) and appended to out.
void append_event_csv_runs(std::vector<gap::Run>& out, const std::string& text,
                           const std::string& name);
/// sample_hz: the tester's export rate (0: the one set by set_generator_b_export_hz, else the
/// drawn set's own). The stations drawn from are those set by set_generator_b_stations (Cars
/// unless set).
std::vector<gap::Run> generator_b_runs(Injection& inj, std::uint64_t seed, double sample_hz = 0);
/// Which stations generator B draws its sets from, for every trial and calibration after the
/// call (set once, before the referee's threads start).
void set_generator_b_stations(sim2::Stations s);
/// Every generator B set exported at this rate instead of its drawn one (0: the drawn rate), for
/// every trial and calibration after the call (set once, before the referee's threads start):
/// the same draws, what the export's rate alone costs the diagnosis.
void set_generator_b_export_hz(double hz);
/// The scenario with the injection switched on (everything else as in base). In the transfer
/// condition roller_friction goes to the roller scenario, the others to the road.
Scenario inject(Scenario base, const Injection& inj);
/// Runs at three pedal ramps (roller: slow, medium, fast; ground: 100, 150, 250 bar/s),
/// conditioned for the diagnosis. truth: the tyre's Pac96 equivalent, when wanted.
std::vector<gap::Run> simulate_runs(const Scenario& s, std::uint64_t seed,
                                    MfParams* truth = nullptr);

/// Start values for the diagnosis: least squares on the pooled points of the runs.
MfParams pooled_start(const std::vector<gap::Run>& runs);

struct TrialResult {
  Injection truth;
  std::vector<std::string> verdict;
  std::vector<std::string> notes;  ///< "cannot separate A from B" notes of the diagnosis
  /// Each candidate's score as the report's table gives it (round, effect, parameters, gain,
  /// BIC drop, decision): what the referee's --why prints under a miss.
  std::vector<std::string> scores;
  /// The pairs the pair search fitted (the report's pairs_tried): the two names and the rule.
  struct PairTried {
    std::string a, b;
    gap::PairRule rule;
  };
  std::vector<PairTried> pairs_tried;
  double estimate = 0.0;   ///< the injected effect's parameter when fitted alone (NaN for none)
  double estimate2 = 0.0;  ///< a pair's second effect's, as estimate
  /// Load transfer's dFz/Fz per m/s^2 where it was named (NaN: not named).
  double load_per_decel_estimate = NAN;
  /// Its band at the ends of published tyres' load laws (NaN: not named, or read at the tyre's
  /// own laws).
  double load_per_decel_low = NAN, load_per_decel_high = NAN;
  double gap_before_n = 0.0, gap_after_n = 0.0, noise_n = 0.0;
  /// Where the injected effect was not named: the smallest magnitude its runs could have shown
  /// beside the effects named, in its parameter's unit (NaN: named, or no reach for it; for a
  /// single effect, also where another effect was named in its place: a reach beside a wrong
  /// name says nothing of what the runs held). reach2: a pair's second effect's.
  double reach = NAN, reach2 = NAN;
  /// The set's runs share one speed (A's runs; B's and C's roller runs): there a relaxation
  /// (sigma / V) and a time offset are one lag, and either name counts for the other.
  bool one_speed = false;
  /// The first verdict is the injected effect, or the diagnosis named both in a "cannot
  /// separate" note (an honest answer: the data do not tell them apart); none: exactly ["none"].
  /// A pair: both effects are in the verdict (either may be covered by a "cannot separate"
  /// note naming it and the effect said in its place).
  bool correct() const;
  bool exact() const;  ///< the first verdict is the injected effect (or ["none"]); a pair: the
                       ///< verdict is exactly the two effects, in either order
};
/// Generator C's runs for an injection (roller and ground conditions): may set the injection's
/// magnitude to the truth in the diagnosis parameter's unit. Throws InputError on a set it cannot
/// make.
using OutsideRuns = std::function<std::vector<gap::Run>(Injection&, std::uint64_t seed)>;
void set_outside_runs(OutsideRuns f);
/// Every trial's diagnosis is given its tyre's own load laws (Injection::tyre_laws), as `brakefit
/// gap --tir` is given the tyre's file (default: not, published tyres' laws). Set before the
/// referee's threads start.
void set_tyre_file_known(bool known);
/// Every diagnosis realigns a late channel (gap::Options::realign_late_channel; default: not).
/// Set before the referee's threads start.
void set_realign_late_channel(bool realign);

/// The seeds bench/gap_referee gives its pair draws, its pair trials and its misspecified sets,
/// here so that a test reruns one of them as the referee ran it.
inline std::uint64_t pair_draw_seed(std::uint64_t seed0, gap::Condition c) {
  return seed0 + 300 * static_cast<std::uint64_t>(c) + 7;
}
inline std::uint64_t pair_trial_seed(std::uint64_t seed0, std::uint64_t index, gap::Condition c) {
  return seed0 * 1000 + 700'000 + index + 100'000 * static_cast<std::uint64_t>(c);
}
inline std::uint64_t misspecified_seed(std::uint64_t index) {
  return 500'000 + index;
}
/// The seeds of the sets whose effect is outside the catalogue (disjoint from the others).
inline std::uint64_t outside_seed(std::uint64_t index) {
  return 600'000 + index;
}

/// No catalogue name is right for the set: a tyre that is not a Magic Formula ("misspecified")
/// or the effects outside the catalogue generators A and B inject ("pressure_bow", a pressure
/// transducer's bow; "friction_fade", friction fading with the energy slid). Correct: `none` or
/// `unexplained`.
bool outside_catalogue(const std::string& effect);
/// The index-th set outside the catalogue (generators A and B), alternately a pressure
/// transducer's bow (0.5-3 % of full scale at mid-range, either sign: at B's 45-75 bar peaks a
/// force read 1.5-9 % off, zero and full scale true) and friction fading with the energy slid
/// (0.2-1.5 per m of energy slid per unit load: B's peaks 1-22 % low, most on slow ramps).
Injection draw_outside(std::uint64_t index, gap::Condition c, Generator g = Generator::B);

/// Simulates the injection in its condition (from referee_null), diagnoses blind, scores.
TrialResult run_trial(const Injection& inj, std::uint64_t seed, const gap::Options& o);
/// The same from a given base (model vs measurement conditions only).
TrialResult run_trial(const Scenario& base, const Injection& inj, std::uint64_t seed,
                      const gap::Options& o);

struct GateCalibration {
  gap::Options options;
  std::vector<double> null_best_gain, null_best_delta_bic;
  std::vector<double> null_points;  ///< each null set's points fitted (its BIC drop per point)
  /// Each null set's held-out gap over its noise floor: the structure the conditioning leaves
  /// on data with no effect (a quantised, rippled export leaves some; see set_gates).
  std::vector<double> null_gap_over_floor;
  int refused = 0;  ///< null sets the diagnosis refused (too few usable runs): not scored
};
/// Diagnoses n null sets of a condition (seeds seed0, seed0+1, ...) and sets the gates above what
/// they show: gain gate = max(start gate, 1.5 x the largest best-candidate gain), BIC likewise
/// per point fitted (set_gates).
GateCalibration calibrate_gates(gap::Condition c, int n, std::uint64_t seed0,
                                const gap::Options& start, Generator g = Generator::A);
/// The gates from the null scores in g (options hold the floors): gain gate = max(floor, 1.5 x
/// the largest null gain), BIC margin per point = 1.5 x the largest null BIC drop per point
/// fitted (bic_margin, the floor, stays as given), the
/// fit-quality factor (gap left above it x the noise floor: `unexplained`) = max(floor, 1.1 x the
/// largest null gap / floor).
void set_gates(GateCalibration& g);

}  // namespace brakefit::sim
