#pragma once
// candump log files: reading and writing only; parsing and formatting are core's pure functions.
#include <string>
#include <vector>

#include "core/can/candump.hpp"

namespace brakefit::drivers {

/// Throws brakefit::InputError naming the file (and line) on unreadable or malformed input.
can::CandumpText read_candump_file(const std::string& path, bool lenient = false);
/// Writes "(sec.usec) iface id#data" lines, byte-compatible with candump -L.
void write_candump_file(const std::string& path, const std::vector<can::LoggedFrame>& frames);

}  // namespace brakefit::drivers
