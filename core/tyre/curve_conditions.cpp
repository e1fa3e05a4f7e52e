#include "core/tyre/curve_conditions.hpp"

#include <fmt/format.h>

#include <cctype>
#include <charconv>
#include <utility>

#include "core/curve.hpp"

namespace brakefit::tyre {

namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

}  // namespace

CurveConditions parse_curve_conditions(std::string_view text, const std::string& filename) {
  CurveConditions out;
  const std::pair<std::string_view, double CurveConditions::*> keys[] = {
      {"wheel_load_n", &CurveConditions::wheel_load_n},
      {"tyre_pressure_bar", &CurveConditions::tyre_pressure_bar},
      {"speed_kmh", &CurveConditions::speed_kmh},
      {"wheel_radius_m", &CurveConditions::wheel_radius_m}};
  std::size_t pos = 0, line_no = 0;
  while (pos < text.size()) {
    std::size_t nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    const std::string_view line = trim(text.substr(pos, nl - pos));
    pos = nl + 1;
    ++line_no;
    if (line.empty() || line.front() != '#') continue;
    const std::string_view body = trim(line.substr(1));
    const std::size_t eq = body.find('=');
    if (eq == std::string_view::npos) continue;
    const std::string_view key = trim(body.substr(0, eq));
    for (const auto& [name, member] : keys) {
      if (key != name) continue;
      const std::string_view v = trim(body.substr(eq + 1));
      double x = NAN;
      const auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), x);
      if (ec != std::errc{} || end != v.data() + v.size() || !std::isfinite(x) || x <= 0)
        throw InputError(
            fmt::format("{}:{}: {}: '{}' is not a positive number", filename, line_no, name, v));
      out.*member = x;
    }
  }
  return out;
}

}  // namespace brakefit::tyre
