#pragma once
// An MF 6.1 tyre from a .tir file's numbers (as a reader of the MDI format gives them: section
// -> key -> value, upper case): the reference values, the scalings and the pure longitudinal
// coefficients, each absent coefficient at MF 6.1's own default (0, a scaling 1).
#include <map>
#include <string>

#include "core/tyre/mf61.hpp"

namespace brakefit::tyre {

using TirNumbers = std::map<std::string, std::map<std::string, double>>;

/// Throws InputError "SOURCE: [SECTION] KEY missing" for FNOMIN, PCX1, PDX1 or PKX1, which no
/// default stands in for.
Mf61Tyre tyre_from_tir(const TirNumbers& numbers, const std::string& source);

}  // namespace brakefit::tyre
