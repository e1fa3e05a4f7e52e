#pragma once
// Generator B runs with the tester out of the way, for tests of an effect's law.
#include <fmt/format.h>

#include <vector>

#include "core/gap/gap.hpp"
#include "sim/referee.hpp"
#include "sim/second/generator.hpp"

namespace brakefit::test {

/// A generator B set's runs with the encoders and the pressure ideal (no ripple, steps, noise or
/// jitter) behind a pressure filter of pressure_filter_s (none at 0): nothing but that filter in
/// the way of the effects' laws. keep_speed_steps: the encoders' quantisation stays (and with it,
/// on a roller held at one speed, each run's reference bias the levelling reads).
inline std::vector<gap::Run> ideal_runs(sim2::SetDraw& set, double pressure_filter_s = 0,
                                        bool keep_speed_steps = false) {
  std::vector<gap::Run> runs;
  for (std::size_t k = 0; k < set.runs.size(); ++k) {
    auto& tx = set.runs[k].tester;
    tx.eccentricity_ref = tx.eccentricity_wheel = 0;
    tx.pressure_step_bar = tx.pressure_noise_bar = tx.jitter_ratio = 0;
    if (!keep_speed_steps) tx.speed_step_mps = 0;
    tx.pressure_filter_s = pressure_filter_s;
    sim::append_event_csv_runs(runs, sim2::simulate_event_csv(set.runs[k]), fmt::format("r{}", k));
  }
  return runs;
}

}  // namespace brakefit::test
