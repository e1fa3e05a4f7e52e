#include "core/can/candump.hpp"

#include <fmt/format.h>

#include <charconv>
#include <limits>

#include "core/curve.hpp"  // InputError

namespace brakefit::can {

namespace {

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

std::uint32_t parse_hex(std::string_view s, const char* what) {
  std::uint32_t v = 0;
  for (char c : s) {
    const int h = hex_value(c);
    if (h < 0) throw CandumpError(fmt::format("{} '{}' is not hexadecimal", what, std::string(s)));
    v = v * 16 + static_cast<std::uint32_t>(h);
  }
  return v;
}

}  // namespace

Frame parse_frame_text(std::string_view text) {
  const auto hash = text.find('#');
  if (hash == std::string_view::npos)
    throw CandumpError(fmt::format("frame '{}' has no '#'", std::string(text)));
  const std::string_view id_text = text.substr(0, hash);
  Frame f;
  if (id_text.size() == 3) {
    f.id = parse_hex(id_text, "standard id");
    if (f.id > 0x7FF)
      throw CandumpError(fmt::format("standard id {} exceeds 7FF", std::string(id_text)));
  } else if (id_text.size() == 8) {
    const std::uint32_t raw = parse_hex(id_text, "extended id");
    f.error = (raw & 0x20000000u) != 0;
    f.id = raw & 0x1FFFFFFFu;
    f.extended = !f.error;
  } else {
    throw CandumpError(fmt::format("id '{}' must have 3 (standard) or 8 (extended) hex digits",
                                   std::string(id_text)));
  }
  std::string_view rest = text.substr(hash + 1);
  std::size_t max_len = 8;
  if (!rest.empty() && rest.front() == '#') {  // CAN FD: flags digit then data
    if (rest.size() < 2) throw CandumpError("CAN FD frame without a flags digit");
    const int flags = hex_value(rest[1]);
    if (flags < 0) throw CandumpError("CAN FD flags digit is not hexadecimal");
    f.fd = true;
    f.fd_flags = static_cast<std::uint8_t>(flags);
    rest.remove_prefix(2);
    max_len = 64;
  } else if (!rest.empty() && (rest.front() == 'R' || rest.front() == 'r')) {
    f.remote = true;
    if (rest.size() > 2)
      throw CandumpError(fmt::format("remote frame '{}' has trailing data", std::string(text)));
    if (rest.size() == 2) {
      const int len = hex_value(rest[1]);
      if (len < 0 || len > 8) throw CandumpError("remote frame length must be 0..8");
      f.len = static_cast<std::uint8_t>(len);
    }
    return f;
  }
  std::size_t n = 0;
  for (std::size_t i = 0; i < rest.size();) {
    if (rest[i] == '.') {
      ++i;
      continue;
    }
    if (i + 1 >= rest.size()) throw CandumpError("odd number of data hex digits");
    const int hi = hex_value(rest[i]), lo = hex_value(rest[i + 1]);
    if (hi < 0 || lo < 0)
      throw CandumpError(fmt::format("data '{}' is not hexadecimal", std::string(rest)));
    if (n >= max_len) throw CandumpError(fmt::format("more than {} data bytes", max_len));
    f.data[n++] = static_cast<std::uint8_t>(hi * 16 + lo);
    i += 2;
  }
  f.len = static_cast<std::uint8_t>(n);
  return f;
}

std::optional<LoggedFrame> parse_candump_line(std::string_view line) {
  while (!line.empty() &&
         (line.back() == '\n' || line.back() == '\r' || line.back() == ' ' || line.back() == '\t'))
    line.remove_suffix(1);
  if (line.empty() || line.front() == '#') return std::nullopt;  // blank or a comment
  if (line.front() != '(')
    throw CandumpError("not a candump line: expected '(seconds.microseconds) <interface> <frame>'");
  const auto close = line.find(')');
  if (close == std::string_view::npos) throw CandumpError("timestamp has no closing ')'");
  const std::string_view ts = line.substr(1, close - 1);
  const auto dot = ts.find('.');
  if (dot == std::string_view::npos || dot == 0 || ts.size() - dot - 1 != 6)
    throw CandumpError(
        fmt::format("timestamp '({})' is not (seconds.microseconds)", std::string(ts)));
  std::int64_t sec = 0, usec = 0;
  auto r1 = std::from_chars(ts.data(), ts.data() + dot, sec);
  auto r2 = std::from_chars(ts.data() + dot + 1, ts.data() + ts.size(), usec);
  if (r1.ec != std::errc() || r1.ptr != ts.data() + dot || r2.ec != std::errc() ||
      r2.ptr != ts.data() + ts.size() || ts.front() == '-' || ts[dot + 1] == '-')
    throw CandumpError(
        fmt::format("timestamp '({})' is not (seconds.microseconds) of digits", std::string(ts)));
  // The pipeline counts nanoseconds in 64 bits: stamps up to 9e9 s (year 2255) fit with room.
  constexpr std::int64_t kMaxSeconds = 9'000'000'000;
  if (sec > kMaxSeconds)
    throw CandumpError(fmt::format("timestamp '({})' is out of range", std::string(ts)));
  std::string_view rest = line.substr(close + 1);
  if (rest.empty() || rest.front() != ' ')
    throw CandumpError("expected a space after the timestamp");
  rest.remove_prefix(1);
  const auto sp = rest.find(' ');
  if (sp == std::string_view::npos || sp == 0)
    throw CandumpError("expected '<interface> <frame>' after the timestamp");
  LoggedFrame out;
  out.t_us = sec * 1000000 + usec;
  out.iface = std::string(rest.substr(0, sp));
  std::string_view frame = rest.substr(sp + 1);
  // candump -L may append nothing else; tolerate trailing blanks only.
  while (!frame.empty() && (frame.back() == ' ' || frame.back() == '\t')) frame.remove_suffix(1);
  if (frame.find(' ') != std::string_view::npos)
    throw CandumpError("unexpected text after the frame");
  out.frame = parse_frame_text(frame);
  return out;
}

std::string format_frame_text(const Frame& f) {
  std::string s;
  if (f.extended || f.error)
    s = fmt::format("{:08X}#", f.id | (f.error ? 0x20000000u : 0u));
  else
    s = fmt::format("{:03X}#", f.id);
  if (f.remote) {
    s += 'R';
    if (f.len > 0 && f.len <= 8) s += fmt::format("{:X}", f.len);
    return s;
  }
  if (f.fd) s += fmt::format("#{:X}", f.fd_flags & 0xF);
  for (std::size_t i = 0; i < f.len; ++i) s += fmt::format("{:02X}", f.data[i]);
  return s;
}

std::string format_candump_line(const LoggedFrame& f) {
  return fmt::format("({:010d}.{:06d}) {} {}", f.t_us / 1000000, f.t_us % 1000000, f.iface,
                     format_frame_text(f.frame));
}

CandumpText parse_candump_text(std::string_view text, const std::string& source, bool lenient) {
  CandumpText out;
  out.frames.reserve(text.size() / 40);
  std::size_t pos = 0;
  while (pos < text.size()) {
    auto nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    const std::string_view line = text.substr(pos, nl - pos);
    pos = nl + 1;
    ++out.lines;
    try {
      if (auto f = parse_candump_line(line))
        out.frames.push_back(std::move(*f));
      else
        ++out.ignored;
    } catch (const CandumpError& e) {
      if (!lenient) throw InputError(fmt::format("{}:{}: {}", source, out.lines, e.what()));
      ++out.malformed;
    }
  }
  return out;
}

}  // namespace brakefit::can
