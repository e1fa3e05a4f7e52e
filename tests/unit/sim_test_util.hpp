#pragma once
// Helpers for tests that run the simulator.
#include <string>

#include "sim/scenario.hpp"
#include "tests/unit/test_util.hpp"

namespace brakefit::test {

/// A scenario from sim/scenarios/<name>.toml.
inline sim::Scenario scenario(const std::string& name) {
  const std::string path = source_path("sim/scenarios/" + name + ".toml");
  return sim::parse_scenario(read_text(path), path);
}

}  // namespace brakefit::test
