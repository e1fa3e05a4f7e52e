#pragma once
// Generator C for the referee: runs an outside generator's script (../shared/gapgen/gen_c.py by
// default) for one injection, reads its event CSVs back through the parser and the pipeline, and
// conditions them, as `brakefit gap` would. Only the referee uses it: no test depends on it.
#include <cstdint>
#include <string>
#include <vector>

#include "sim/referee.hpp"

namespace brakefit::bench {

/// The runs of one set from the script (bench from the injection's condition, its effect and
/// magnitude, the seed). Sets inj.magnitude to the truth in the diagnosis parameter's unit:
/// slip_offset's sign flipped (the script reads the wheel too fast: measured slip = true - m),
/// load transfer's h/L as the peak's relative change per m/s^2 (q of dfz_per_decel_s2_per_m) of
/// the drawn tyre at the set's load. Throws InputError when the script fails.
std::vector<gap::Run> outside_runs(const std::string& script, sim::Injection& inj,
                                   std::uint64_t seed);

}  // namespace brakefit::bench
