#pragma once
// The referee's rows of single effects: the gates calibrated on one generator's null sets, and a
// condition's trials from one generator diagnosed with them (straight or crossed), scored and
// printed; its pairs and detection curves where asked for.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/gap/gap.hpp"
#include "sim/referee.hpp"

namespace brakefit::bench {

struct Settings {
  int threads = 2;
  int trials = 200, trials_other = 80, calib = 30, misspecified = 30;
  int pairs = 0;    ///< --pairs: pair trials per row (roller and ground; C on the ground)
  int outside = 0;  ///< --outside: sets outside the catalogue per row (A, B; roller, ground)
  int detection = 0, detection_levels = 6;  ///< --detection: sets per magnitude (straight rows)
  double null_share = 0.3;
  std::uint64_t seed = 1;
  std::vector<std::string> only;  ///< --only: run just the trials drawing these effects
  std::vector<int> pick;  ///< --pick: just these trials and pair trials, by the index a miss names
  int why = 0;  ///< --why 1: each miss's diagnosis notes on stderr; 2: also each hit, one line
};

/// The gates calibrated on null sets of one generator (seeds from 1 000 000, disjoint from the
/// trials').
sim::GateCalibration calibrate(gap::Condition c, const Settings& st, sim::Generator gen);

/// Trials from trial_gen diagnosed with gates calibrated on gate_gen (crossed when they differ).
/// Prints the tables and every miss; returns the figures for the referee's JSON.
nlohmann::ordered_json run_condition(gap::Condition c, const Settings& st, sim::Generator trial_gen,
                                     const sim::GateCalibration& gates, sim::Generator gate_gen);

}  // namespace brakefit::bench
