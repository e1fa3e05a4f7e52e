#include "core/can/dbc.hpp"

#include <fmt/format.h>

#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <stdexcept>

#include "core/curve.hpp"  // InputError

namespace brakefit::can {

const SignalDef& MessageDef::signal(std::string_view n) const {
  for (const auto& s : signals)
    if (s.name == n) return s;
  throw std::out_of_range(fmt::format("message {} has no signal {}", name, std::string(n)));
}

namespace {

/// A cursor over one line of a DBC file: no regex (a long line cannot exhaust the stack), every
/// number range-checked (no std::stoul exceptions, no start bit 4294967295).
class Cursor {
 public:
  Cursor(std::string_view line, const std::string& where) : s_(line), where_(where) {}
  void ws() {
    while (i_ < s_.size() && (s_[i_] == ' ' || s_[i_] == '\t')) ++i_;
  }
  [[noreturn]] void fail(const std::string& what) const {
    throw InputError(fmt::format("{}: {} (at column {})", where_, what, i_ + 1));
  }
  void expect(char c) {
    ws();
    if (i_ >= s_.size() || s_[i_] != c) fail(fmt::format("expected '{}'", c));
    ++i_;
  }
  bool accept(char c) {
    ws();
    if (i_ < s_.size() && s_[i_] == c) {
      ++i_;
      return true;
    }
    return false;
  }
  std::string word(const char* what) {
    ws();
    const auto b = i_;
    while (i_ < s_.size() && (std::isalnum(static_cast<unsigned char>(s_[i_])) || s_[i_] == '_'))
      ++i_;
    if (b == i_) fail(fmt::format("expected {}", what));
    return std::string(s_.substr(b, i_ - b));
  }
  std::uint64_t unsigned_in(const char* what, std::uint64_t lo, std::uint64_t hi) {
    ws();
    std::uint64_t v = 0;
    const auto r = std::from_chars(s_.data() + i_, s_.data() + s_.size(), v);
    if (r.ec == std::errc::result_out_of_range || (r.ec == std::errc() && (v < lo || v > hi)))
      fail(fmt::format("{} must be {}..{}", what, lo, hi));
    if (r.ec != std::errc()) fail(fmt::format("expected {}", what));
    i_ = static_cast<std::size_t>(r.ptr - s_.data());
    return v;
  }
  double number(const char* what) {
    ws();
    if (i_ < s_.size() && s_[i_] == '+') ++i_;  // from_chars takes no leading '+'
    double v = 0;
    const auto r = std::from_chars(s_.data() + i_, s_.data() + s_.size(), v);
    if (r.ec != std::errc() || !std::isfinite(v))
      fail(fmt::format("expected {} (a finite number)", what));
    i_ = static_cast<std::size_t>(r.ptr - s_.data());
    return v;
  }
  std::string quoted(const char* what) {
    expect('"');
    const auto close = s_.find('"', i_);
    if (close == std::string_view::npos) fail(fmt::format("{} has no closing '\"'", what));
    std::string out(s_.substr(i_, close - i_));
    i_ = close + 1;
    return out;
  }
  char one_of(const char* set, const char* what) {
    if (i_ < s_.size() && std::strchr(set, s_[i_]) && s_[i_] != '\0') return s_[i_++];
    fail(fmt::format("expected {}", what));
  }

 private:
  std::string_view s_;
  const std::string& where_;
  std::size_t i_ = 0;
};

constexpr std::uint64_t kMaxDlc = 64;  // CAN FD; Frame::data holds 64 bytes

MessageDef parse_bo(Cursor& c) {
  MessageDef msg;
  // Extended ids carry bit 31 in DBC files.
  msg.id = static_cast<std::uint32_t>(c.unsigned_in("the message id", 0, 0x9FFFFFFFull));
  msg.name = c.word("a message name");
  c.expect(':');
  msg.dlc = static_cast<unsigned>(c.unsigned_in("the DLC", 0, kMaxDlc));
  c.word("the sender");
  return msg;
}

SignalDef parse_sg(Cursor& c) {
  SignalDef s;
  s.name = c.word("a signal name");
  c.expect(':');
  s.start_bit = static_cast<unsigned>(c.unsigned_in("the start bit", 0, 8 * kMaxDlc - 1));
  c.expect('|');
  s.length = static_cast<unsigned>(c.unsigned_in("the length", 1, 64));
  c.expect('@');
  if (c.one_of("01", "byte order @0 or @1") != '1')
    c.fail("only Intel byte order (@1) is supported");
  s.is_signed = c.one_of("+-", "'+' or '-'") == '-';
  c.expect('(');
  s.scale = c.number("the scale");
  if (s.scale == 0) c.fail("the scale must not be 0");
  c.expect(',');
  s.offset = c.number("the offset");
  c.expect(')');
  c.expect('[');
  s.min = c.number("the minimum");
  c.expect('|');
  s.max = c.number("the maximum");
  c.expect(']');
  s.unit = c.quoted("the unit");
  return s;
}

}  // namespace

std::vector<MessageDef> parse_dbc(std::string_view text, const std::string& source) {
  std::vector<MessageDef> out;
  std::size_t line_no = 0, pos = 0;
  while (pos < text.size()) {
    auto nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    std::string_view line = text.substr(pos, nl - pos);
    pos = nl + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    const std::string where = fmt::format("{}:{}", source, line_no);
    const auto first = line.find_first_not_of(" \t");
    if (first == std::string_view::npos) continue;
    const std::string_view body = line.substr(first);
    if (first == 0 && body.substr(0, 4) == "BO_ ") {
      Cursor c(body.substr(4), where);
      out.push_back(parse_bo(c));
    } else if (first > 0 && body.substr(0, 4) == "SG_ ") {
      if (out.empty()) throw InputError(fmt::format("{}: SG_ before any BO_", where));
      Cursor c(body.substr(4), where);
      SignalDef s = parse_sg(c);
      if (std::uint64_t{s.start_bit} + s.length > 8 * std::uint64_t{out.back().dlc})
        throw InputError(fmt::format("{}: signal {} does not fit the message", where, s.name));
      out.back().signals.push_back(std::move(s));
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
  std::uint64_t raw = extract_raw(f, s);
  double v;
  if (s.is_signed) {  // sign-extend, then two's complement (defined in C++20), any length to 64
    if (s.length < 64 && (raw >> (s.length - 1)) & 1u) raw |= ~std::uint64_t{0} << s.length;
    v = static_cast<double>(static_cast<std::int64_t>(raw));
  } else {
    v = static_cast<double>(raw);
  }
  return v * s.scale + s.offset;
}

void encode_signal(Frame& f, const SignalDef& s, double physical) {
  if (s.length == 0 || s.length > 64) return;  // parse_dbc rejects these
  double r = std::round((physical - s.offset) / s.scale);
  if (std::isnan(r)) r = 0;
  // The largest doubles that convert exactly (2^63 - 1 and 2^64 - 1 round up to 2^63 and 2^64).
  const int bits = static_cast<int>(s.length) - (s.is_signed ? 1 : 0);
  const double lo = s.is_signed ? -std::ldexp(1.0, bits) : 0.0;
  const double hi = std::min(std::ldexp(1.0, bits) - 1, std::nextafter(std::ldexp(1.0, bits), 0.0));
  r = std::min(std::max(r, lo), hi);
  const auto raw = s.is_signed ? static_cast<std::uint64_t>(static_cast<std::int64_t>(r))
                               : static_cast<std::uint64_t>(r);
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
