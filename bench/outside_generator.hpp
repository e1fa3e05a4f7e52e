#pragma once
// Generator C for the referee: runs an outside generator's script (../shared/gapgen/gen_c.py by
// default) for one injection, reads its event CSVs back through the parser and the pipeline, and
// conditions them, as `brakefit gap` would. Only the referee uses it: no test depends on it.
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "sim/referee.hpp"

namespace brakefit::bench {

/// The runs of one set from the script (bench from the injection's condition, its effect and
/// magnitude, the seed). Sets inj.magnitude to the truth in the diagnosis parameter's unit:
/// slip_offset's sign flipped (the script reads the wheel too fast: measured slip = true - m),
/// load transfer's h/L as the peak's relative change per m/s^2 (q of dfz_per_decel_s2_per_m) of
/// the drawn tyre at the set's load. Throws GeneratorError when the script fails: a set that was
/// never made is the referee's failure, not a set the diagnosis refused (InputError).
struct GeneratorError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Empty when `python3` (the interpreter outside_runs calls) can import what the script needs;
/// else what is missing and the Debian package that has it.
std::string outside_generator_missing();

std::vector<gap::Run> outside_runs(const std::string& script, sim::Injection& inj,
                                   std::uint64_t seed);

}  // namespace brakefit::bench
