#pragma once
// The referee's sets outside the catalogue: generator A's and B's runs with an effect the
// diagnosis has no name for (a pressure transducer's bow, friction fading with the energy slid),
// diagnosed blind; right where the verdict is `none` or `unexplained`, a false claim where it names
// one.
#include <nlohmann/json.hpp>
#include <string>

#include "core/gap/gap.hpp"
#include "sim/referee.hpp"

namespace brakefit::bench {

struct OutsideSettings {
  int n = 0;  ///< sets, the two effects alternately
  int threads = 2;
  int why = 0;  ///< 1: each false claim's notes
};
/// Sets of a condition from trial_gen (A and B, roller and ground: C draws no such effect, an
/// empty result for it), diagnosed with the given gates. Prints the count and every false claim;
/// returns the figures for the referee's JSON.
nlohmann::ordered_json run_outside(gap::Condition c, sim::Generator trial_gen,
                                   const gap::Options& gates, const OutsideSettings& st,
                                   const std::string& cname);

}  // namespace brakefit::bench
