#pragma once
// Detection curves: for each effect of a condition, sets at fixed magnitudes from a quarter of
// the drawn range's low end up to its high end; the share of sets that name the effect at each,
// and the smallest magnitude named in 90 % of them (what a user can expect to see).
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/gap/gap.hpp"
#include "sim/referee.hpp"

namespace brakefit::bench {

struct DetectionSettings {
  int sets = 10;   ///< sets per magnitude
  int levels = 6;  ///< magnitudes per effect, geometric from lo / 4 to hi
  int threads = 2;
  std::uint64_t seed0 = 1;
  int why = 0;                    ///< 1: each miss's notes and candidates' scores on stderr
  std::vector<std::string> only;  ///< these effects' curves alone (empty: every effect's)
};

/// Prints the curves of one condition and generator under the given gates, and each set missed on
/// stderr (its index, verdict, gap and reach: a set at a magnitude that is named in most is
/// looked at one by one); returns them for the referee's JSON. Generator B draws its own load
/// transfer (the vehicle decides it): left out.
nlohmann::ordered_json run_detection(gap::Condition c, sim::Generator g, const gap::Options& gates,
                                     const DetectionSettings& st, const std::string& cname);

}  // namespace brakefit::bench
