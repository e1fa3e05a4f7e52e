#pragma once
// A reader for MF-Tyre property files (.tir, the TNO/ADAMS "MDI" format): [SECTION] headers,
// KEY = value lines, '$' comments (to the end of the line) and '!' comment lines, quoted strings.
// Written for the second simulator (sim/second): it shares no code with sim/tyre.*.
#include <map>
#include <string>
#include <string_view>

namespace brakefit::sim2 {

struct TirFile {
  std::string source;
  /// section (upper case, without brackets) -> key (upper case) -> numeric value.
  std::map<std::string, std::map<std::string, double>> numbers;
  /// The same for quoted string values.
  std::map<std::string, std::map<std::string, std::string>> strings;
  /// A numeric value; throws InputError "SOURCE: [SECTION] KEY missing" when absent.
  double at(const std::string& section, const std::string& key) const;
  /// A numeric value, or fallback when absent (MF 6.1 coefficients default to 0, scalings to 1).
  double get(const std::string& section, const std::string& key, double fallback) const;
};

/// Throws InputError "SOURCE:LINE: ..." for a line that is neither a section, a KEY = value nor a
/// comment, or a value that is neither a number nor a quoted string.
TirFile parse_tir(std::string_view text, const std::string& source);

}  // namespace brakefit::sim2
