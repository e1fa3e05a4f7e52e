#include "core/curve_csv.hpp"

#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <vector>

namespace brakefit {

const char* to_string(SlipUnit u) {
  return u == SlipUnit::Percent ? "percent" : "ratio";
}

namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r'))
    s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r'))
    s.remove_suffix(1);
  return s;
}

std::vector<std::string_view> split(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  for (;;) {
    const auto comma = line.find(',', start);
    out.push_back(
        trim(line.substr(start, comma == std::string_view::npos ? line.npos : comma - start)));
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return out;
}

}  // namespace

ParsedCurve parse_curve_csv(std::string_view text, const std::string& filename) {
  auto fail = [&](std::size_t line, const std::string& msg) -> InputError {
    return InputError(fmt::format("{}:{}: {}", filename, line, msg));
  };
  ParsedCurve out;
  std::size_t line_no = 0, pos = 0;
  long slip_col = -1, force_col = -1;
  bool have_header = false;
  std::size_t header_cols = 0;
  while (pos <= text.size()) {
    auto nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    const std::string_view line = trim(text.substr(pos, nl - pos));
    pos = nl + 1;
    ++line_no;
    if (line.empty() || line.front() == '#') {
      if (nl == text.size()) break;
      continue;
    }
    const auto cells = split(line);
    if (!have_header) {
      for (std::size_t i = 0; i < cells.size(); ++i) {
        if (cells[i] == "slip" || cells[i] == "slip_ratio") {
          slip_col = static_cast<long>(i);
          out.input_unit = SlipUnit::Ratio;
        } else if (cells[i] == "slip_pct") {
          slip_col = static_cast<long>(i);
          out.input_unit = SlipUnit::Percent;
        } else if (cells[i] == "force_n") {
          force_col = static_cast<long>(i);
        }
      }
      if (slip_col < 0 || force_col < 0)
        throw fail(line_no, fmt::format("header must name a slip column ('slip' as a ratio or "
                                        "'slip_pct' in percent) and 'force_n'; got '{}'",
                                        std::string(line)));
      header_cols = cells.size();
      have_header = true;
      continue;
    }
    if (cells.size() != header_cols)
      throw fail(line_no, fmt::format("expected {} columns as in the header, got {}", header_cols,
                                      cells.size()));
    auto number = [&](long col, const char* name) {
      const std::string_view cell = cells[static_cast<std::size_t>(col)];
      double v = 0.0;
      const auto [ptr, ec] = std::from_chars(cell.data(), cell.data() + cell.size(), v);
      if (cell.empty() || ec != std::errc() || ptr != cell.data() + cell.size())
        throw fail(line_no,
                   fmt::format("column '{}': '{}' is not a number", name, std::string(cell)));
      if (!std::isfinite(v))
        throw fail(line_no,
                   fmt::format("column '{}': value '{}' is not finite", name, std::string(cell)));
      return v;
    };
    const char* slip_name = out.input_unit == SlipUnit::Percent ? "slip_pct" : "slip";
    double slip = number(slip_col, slip_name);
    const double force = number(force_col, "force_n");
    if (out.input_unit == SlipUnit::Percent) slip /= 100.0;
    if (slip < 0.0 || slip > 1.0)
      throw fail(line_no,
                 fmt::format("column '{}': slip {} is outside [0, 1] as a ratio ({})", slip_name,
                             std::string(cells[static_cast<std::size_t>(slip_col)]),
                             out.input_unit == SlipUnit::Percent ? "0..100 %" : "0..1"));
    out.curve.slip_ratio.push_back(slip);
    out.curve.force_n.push_back(force);
    if (nl == text.size()) break;
  }
  if (!have_header)
    throw fail(line_no, "no header line (expected 'slip,force_n' or 'slip_pct,force_n')");
  if (out.curve.size() < kMinCurvePoints)
    throw fail(line_no, fmt::format("only {} data points; at least {} are needed", out.curve.size(),
                                    kMinCurvePoints));
  return out;
}

}  // namespace brakefit
