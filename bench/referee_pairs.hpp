#pragma once
// The referee's pairs: two effects injected into one set (generators A and B, roller and
// ground; generator C on the ground, two of its effects at one magnitude), diagnosed blind;
// scored on whether forward selection names both, and on each one's magnitude where it is named.
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/gap/gap.hpp"
#include "sim/referee.hpp"

namespace brakefit::bench {

struct PairSettings {
  int n = 0;                ///< pair trials
  std::uint64_t seed0 = 1;  ///< the referee's --seed
  int threads = 2;
  int why = 0;                    ///< 1: each miss's notes; 2: each hit's line too
  std::vector<std::string> only;  ///< only the pairs with one of these effects (same draws)
  std::vector<int> pick;          ///< only these pairs, by index (a miss rerun alone)
};
/// Pair trials of a condition from trial_gen, diagnosed with the given gates. Prints the table and
/// every miss; returns the figures for the referee's JSON.
nlohmann::ordered_json run_pairs(gap::Condition c, sim::Generator trial_gen,
                                 const gap::Options& gates, const PairSettings& st,
                                 const std::string& cname);

}  // namespace brakefit::bench
