#pragma once
// candump log lines (can-utils 2020.11, `candump -L` / `-l`): "(%010lu.%06lu) <iface> <frame>"
// where <frame> is "123#DEADBEEF" (3 hex digits = standard id, 8 = extended), "123#R" or "123#R5"
// (remote), "123##1..." (CAN FD with a flags digit). Pure text <-> frame functions.
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "core/can/frame.hpp"

namespace brakefit::can {

class CandumpError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A logged frame, std::nullopt for lines canplayer ignores (not starting with '('), or throws
/// CandumpError describing what is malformed.
std::optional<LoggedFrame> parse_candump_line(std::string_view line);
/// "123#11223344" / "12345678#R" / "123##1AABB".
Frame parse_frame_text(std::string_view text);
/// The line without a newline, byte-compatible with candump -L.
std::string format_candump_line(const LoggedFrame& f);
std::string format_frame_text(const Frame& f);

struct CandumpText {
  std::vector<LoggedFrame> frames;
  std::size_t lines = 0;
  std::size_t ignored =
      0;  ///< blank and '#' comment lines (any other line is a frame or malformed)
  std::size_t malformed = 0;  ///< skipped in lenient mode
};
/// Parses a whole log. Malformed lines throw InputError "SOURCE:LINE: ..." unless lenient, where
/// they are counted and skipped.
CandumpText parse_candump_text(std::string_view text, const std::string& source, bool lenient);

}  // namespace brakefit::can
