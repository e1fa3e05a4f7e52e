#pragma once
// DBC subset (BO_ messages and SG_ signals, Intel byte order) and a table-driven signal codec.
// Pure: text in, definitions out; frame bytes in, physical values out.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "core/can/frame.hpp"

namespace brakefit::can {

struct SignalDef {
  std::string name;
  unsigned start_bit = 0;  ///< Intel (little-endian) start bit
  unsigned length = 0;     ///< bits, 1..64
  bool is_signed = false;
  double scale = 1.0;
  double offset = 0.0;
  double min = 0.0;
  double max = 0.0;
  std::string unit;
};

struct MessageDef {
  std::uint32_t id = 0;
  std::string name;
  unsigned dlc = 8;
  std::vector<SignalDef> signals;
  const SignalDef& signal(std::string_view name) const;  ///< throws std::out_of_range
};

/// Parses BO_/SG_ lines; other DBC sections are skipped. Throws brakefit::InputError "SOURCE:LINE:
/// ...".
std::vector<MessageDef> parse_dbc(std::string_view text, const std::string& source);

std::uint64_t extract_raw(const Frame& f, const SignalDef& s);
double decode_signal(const Frame& f, const SignalDef& s);
/// Rounds (physical - offset)/scale to the nearest raw value, clamped to the signal's bit range.
void encode_signal(Frame& f, const SignalDef& s, double physical);

}  // namespace brakefit::can
