#pragma once
// The bench and vehicle physics simulator. Integrates the wheel (and on the ground the vehicle)
// with a fixed step <= 0.1 ms, linearly implicit in the wheel speed so stiff tyres stay stable,
// and emits the CAN frames a real bench would send (config/brakefit.dbc): encoder x4 counts with
// edge times, brake pressure, the tester's force reading, the test state.
#include <functional>
#include <string>
#include <vector>

#include "core/can/frame.hpp"
#include "core/magic_formula.hpp"
#include "core/pipeline/calibration.hpp"
#include "sim/scenario.hpp"

namespace brakefit::sim {

struct SimResult {
  std::vector<can::LoggedFrame> frames;
  pipeline::Calibration calibration;  ///< what a station would configure for this bench
  MfParams truth;      ///< Pac96 equivalent of the tyre on this surface at the static load
  MfParams tyre_road;  ///< the same tyre on the road (friction ratio 1)
  std::vector<std::string> effects;  ///< active effects
  double duration_s = 0.0;
  double end_t_s = 0.0;  ///< switch-off (roller) or wheel lock (ground)
  std::string end_reason;
  double peak_force_n = 0.0;  ///< largest tyre force during the test
};

/// Deterministic from scenario.seed.
SimResult simulate(const Scenario& s);
/// The ground-truth document written beside a recording (schema brakefit.truth/1).
std::string truth_json(const Scenario& s, const SimResult& r, const std::string& scenario_text);

}  // namespace brakefit::sim
