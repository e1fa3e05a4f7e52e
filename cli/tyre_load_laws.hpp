#pragma once
// The tyre's own load laws for the gap diagnosis (brakefit gap --tir): its MF 6.1 file read and
// linearised at the runs' wheel load.
#include <string>
#include <vector>

#include "core/gap/run.hpp"
#include "core/tyre/load_laws.hpp"

namespace brakefit::cli {

/// The laws of the .tir file at path, at the median wheel load of runs. Throws ExitError (data
/// error) naming the file where it is no MF 6.1 file, or where the runs carry no wheel load.
tyre::LoadLaws tyre_load_laws_from(const std::string& path, const std::vector<gap::Run>& runs);

}  // namespace brakefit::cli
