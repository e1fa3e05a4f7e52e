#pragma once
// Generator B's sets as a station exports them, read back into the diagnosis's runs.
#include <fmt/format.h>

#include <vector>

#include "core/gap/gap.hpp"
#include "sim/referee.hpp"
#include "sim/second/generator.hpp"

namespace brakefit::test {

/// A set's runs as exported and as they would read with ideal encoders (no ripple, no steps).
inline std::vector<gap::Run> conditioned(const sim2::SetDraw& set, bool ideal) {
  std::vector<gap::Run> out;
  for (std::size_t k = 0; k < set.runs.size(); ++k) {
    auto r = set.runs[k];
    if (ideal) {
      r.tester.eccentricity_ref = r.tester.eccentricity_wheel = 0;
      r.tester.speed_step_mps = 0;
    }
    sim::append_event_csv_runs(out, sim2::simulate_event_csv(r), fmt::format("r{}", k));
  }
  return out;
}

}  // namespace brakefit::test
