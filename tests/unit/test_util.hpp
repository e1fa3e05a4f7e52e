#pragma once
// Helpers shared by the unit tests.
#include <fstream>
#include <sstream>
#include <string>

namespace brakefit::test {

/// A path inside the source tree.
inline std::string source_path(const std::string& relative) {
  return std::string(BRAKEFIT_SOURCE_DIR) + "/" + relative;
}

inline std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace brakefit::test
