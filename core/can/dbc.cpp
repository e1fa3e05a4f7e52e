#include "core/can/dbc.hpp"

#include <fmt/format.h>

#include <cmath>
#include <regex>
#include <stdexcept>

#include "core/curve.hpp"  // InputError

namespace brakefit::can {

const SignalDef& MessageDef::signal(std::string_view n) const {
  for (const auto& s : signals)
    if (s.name == n) return s;
  throw std::out_of_range(fmt::format("message {} has no signal {}", name, std::string(n)));
}

std::vector<MessageDef> parse_dbc(std::string_view text, const std::string& source) {
  static const std::regex bo(R"(^BO_\s+(\d+)\s+(\w+)\s*:\s*(\d+)\s+\w+\s*$)");
  static const std::regex sg(
      R"(^\s+SG_\s+(\w+)\s*:\s*(\d+)\|(\d+)@([01])([+-])\s*\(([-+0-9.eE]+),([-+0-9.eE]+)\)\s*\[([-+0-9.eE]+)\|([-+0-9.eE]+)\]\s*\"([^\"]*)\".*$)");
  std::vector<MessageDef> out;
  std::size_t line_no = 0, pos = 0;
  while (pos < text.size()) {
    auto nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    std::string line(text.substr(pos, nl - pos));
    pos = nl + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::smatch m;
    if (line.rfind("BO_ ", 0) == 0) {
      if (!std::regex_match(line, m, bo))
        throw InputError(fmt::format("{}:{}: malformed BO_ line", source, line_no));
      MessageDef msg;
      msg.id = static_cast<std::uint32_t>(std::stoul(m[1]));
      msg.name = m[2];
      msg.dlc = static_cast<unsigned>(std::stoul(m[3]));
      out.push_back(msg);
    } else if (line.find("SG_ ") != std::string::npos &&
               line.find_first_not_of(" \t") == line.find("SG_")) {
      if (!std::regex_match(line, m, sg))
        throw InputError(fmt::format("{}:{}: malformed SG_ line", source, line_no));
      if (out.empty()) throw InputError(fmt::format("{}:{}: SG_ before any BO_", source, line_no));
      if (m[4] != "1")
        throw InputError(
            fmt::format("{}:{}: only Intel byte order (@1) is supported", source, line_no));
      SignalDef s;
      s.name = m[1];
      s.start_bit = static_cast<unsigned>(std::stoul(m[2]));
      s.length = static_cast<unsigned>(std::stoul(m[3]));
      s.is_signed = m[5] == "-";
      s.scale = std::stod(m[6]);
      s.offset = std::stod(m[7]);
      s.min = std::stod(m[8]);
      s.max = std::stod(m[9]);
      s.unit = m[10];
      if (s.length == 0 || s.length > 64 || s.start_bit + s.length > 8 * out.back().dlc)
        throw InputError(
            fmt::format("{}:{}: signal {} does not fit the message", source, line_no, s.name));
      out.back().signals.push_back(s);
    }
  }
  return out;
}

std::uint64_t extract_raw(const Frame& f, const SignalDef& s) {
  std::uint64_t v = 0;
  for (unsigned i = 0; i < s.length; ++i) {
    const unsigned bit = s.start_bit + i;
    if ((f.data[bit / 8] >> (bit % 8)) & 1u) v |= std::uint64_t{1} << i;
  }
  return v;
}

double decode_signal(const Frame& f, const SignalDef& s) {
  if (s.length == 0 || s.length > 64)
    return s.offset;  // parse_dbc rejects these; stay defined anyway
  const std::uint64_t raw = extract_raw(f, s);
  double v;
  if (s.is_signed && s.length < 64 && (raw >> (s.length - 1)) & 1u)
    v = static_cast<double>(static_cast<std::int64_t>(raw) - (std::int64_t{1} << s.length));
  else
    v = static_cast<double>(raw);
  return v * s.scale + s.offset;
}

void encode_signal(Frame& f, const SignalDef& s, double physical) {
  double r = std::round((physical - s.offset) / s.scale);
  const double lo = s.is_signed ? -std::ldexp(1.0, static_cast<int>(s.length) - 1) : 0.0;
  const double hi = s.is_signed ? std::ldexp(1.0, static_cast<int>(s.length) - 1) - 1
                                : std::ldexp(1.0, static_cast<int>(s.length)) - 1;
  r = std::min(std::max(r, lo), hi);
  const auto raw = static_cast<std::uint64_t>(static_cast<std::int64_t>(r));
  for (unsigned i = 0; i < s.length; ++i) {
    const unsigned bit = s.start_bit + i;
    auto& byte = f.data[bit / 8];
    const auto mask = static_cast<std::uint8_t>(1u << (bit % 8));
    if ((raw >> i) & 1u)
      byte = static_cast<std::uint8_t>(byte | mask);
    else
      byte = static_cast<std::uint8_t>(byte & ~mask);
  }
}

}  // namespace brakefit::can
