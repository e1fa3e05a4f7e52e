#include "core/pipeline/event_csv.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cmath>

#include "core/curve.hpp"

namespace brakefit::pipeline {

/// An export's start pressure at most this share of its largest pressure (see event_csv_settings).
constexpr double kExportStartShareOfMax = 0.1;

namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r'))
    s.remove_suffix(1);
  return s;
}

/// Rows that share a stamp (a coarse clock) keep their order and are spread evenly up to the next
/// stamp (the last ones by the median interval): averaging them would invent values between a
/// quantised channel's levels, and dropping them loses data.
void spread_repeated_stamps(std::vector<Sample>& s) {
  std::vector<std::int64_t> dts;
  for (std::size_t i = 1; i < s.size(); ++i)
    if (s[i].t_ns > s[i - 1].t_ns) dts.push_back(s[i].t_ns - s[i - 1].t_ns);
  if (dts.empty()) return;
  std::nth_element(dts.begin(), dts.begin() + static_cast<long>(dts.size() / 2), dts.end());
  const std::int64_t median = dts[dts.size() / 2];
  for (std::size_t i = 0; i < s.size();) {
    std::size_t j = i + 1;
    while (j < s.size() && s[j].t_ns == s[i].t_ns) ++j;
    if (j - i > 1) {
      const std::int64_t t0 = s[i].t_ns;
      const std::int64_t span =
          j < s.size() ? s[j].t_ns - t0 : median * static_cast<std::int64_t>(j - i);
      for (std::size_t k = i + 1; k < j; ++k)
        s[k].t_ns = t0 + span * static_cast<std::int64_t>(k - i) / static_cast<std::int64_t>(j - i);
    }
    i = j;
  }
}

}  // namespace

EventSettings event_csv_settings(const EventCsv& ev, EventSettings configured) {
  double max_bar = 0;
  for (const auto& s : ev.samples) max_bar = std::max(max_bar, s.pressure_bar);
  const double scale =
      configured.start_pressure_bar > 0 && max_bar > 0
          ? std::min(1.0, kExportStartShareOfMax * max_bar / configured.start_pressure_bar)
          : 1.0;
  configured.start_pressure_bar *= scale;
  configured.release_pressure_bar *= scale;
  return configured;
}

bool looks_like_event_csv(std::string_view text) {
  const auto first = trim(text.substr(0, text.find('\n')));
  return first.rfind("# bench=", 0) == 0 || first.rfind("#bench=", 0) == 0 ||
         first.rfind("t_s,", 0) == 0;
}

EventCsv parse_event_csv(std::string_view text, const std::string& source) {
  EventCsv out;
  std::string meta = "[bench]\n";
  std::vector<std::string> cols;
  std::size_t line_no = 0, pos = 0;
  int c_t = -1, c_ref = -1, c_wheel = -1, c_p = -1, c_f = -1;
  bool timing_given = false;  // else the speeds of a file from elsewhere are taken at the stamp
  auto fail = [&](const std::string& msg) {
    return InputError(fmt::format("{}:{}: {}", source, line_no, msg));
  };
  while (pos < text.size()) {
    auto nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    const std::string_view line = trim(text.substr(pos, nl - pos));
    pos = nl + 1;
    ++line_no;
    if (line.empty()) continue;
    if (line.front() == '#') {
      const auto body = trim(line.substr(1));
      const auto eq = body.find('=');
      if (eq == std::string_view::npos) continue;  // a plain comment
      const auto key = trim(body.substr(0, eq)), value = trim(body.substr(eq + 1));
      if (key == "event_id" || key == "end_reason") continue;  // informational
      if (key == "bench")
        meta += fmt::format("kind = \"{}\"\n", std::string(value));
      else if (key == "speed_timing")
        meta += fmt::format("speed_timing = \"{}\"\n", std::string(value)), timing_given = true;
      else
        meta += fmt::format("{} = {}\n", std::string(key), std::string(value));
      continue;
    }
    if (cols.empty()) {
      std::size_t start = 0;
      for (;;) {
        const auto comma = line.find(',', start);
        cols.emplace_back(
            trim(line.substr(start, comma == std::string_view::npos ? line.npos : comma - start)));
        if (comma == std::string_view::npos) break;
        start = comma + 1;
      }
      for (std::size_t i = 0; i < cols.size(); ++i) {
        const auto ii = static_cast<int>(i);
        if (cols[i] == "t_s")
          c_t = ii;
        else if (cols[i] == "v_ref_mps")
          c_ref = ii;
        else if (cols[i] == "v_wheel_mps")
          c_wheel = ii;
        else if (cols[i] == "pressure_bar")
          c_p = ii;
        else if (cols[i] == "force_n")
          c_f = ii;
      }
      if (c_t < 0 || c_ref < 0 || c_wheel < 0 || c_p < 0)
        throw fail(
            "header must have t_s, v_ref_mps, v_wheel_mps and pressure_bar (force_n optional)");
      out.has_force = c_f >= 0;
      continue;
    }
    std::vector<double> v;
    std::size_t start = 0;
    for (;;) {
      const auto comma = line.find(',', start);
      const auto cell =
          trim(line.substr(start, comma == std::string_view::npos ? line.npos : comma - start));
      double x = 0;
      const auto [p, ec] = std::from_chars(cell.data(), cell.data() + cell.size(), x);
      if (cell.empty() || ec != std::errc() || p != cell.data() + cell.size() || !std::isfinite(x))
        throw fail(fmt::format("column '{}': '{}' is not a finite number",
                               v.size() < cols.size() ? cols[v.size()] : "?", std::string(cell)));
      v.push_back(x);
      if (comma == std::string_view::npos) break;
      start = comma + 1;
    }
    if (v.size() != cols.size())
      throw fail(fmt::format("expected {} columns, got {}", cols.size(), v.size()));
    Sample s;
    const double t_s = v[static_cast<std::size_t>(c_t)];
    if (std::abs(t_s) > 1e9) throw fail(fmt::format("t_s {} is out of range", t_s));
    s.t_ns = std::llround(t_s * 1e9);
    s.v_ref_mps = v[static_cast<std::size_t>(c_ref)];
    s.v_wheel_mps = v[static_cast<std::size_t>(c_wheel)];
    s.pressure_bar = v[static_cast<std::size_t>(c_p)];
    if (c_f >= 0) s.force_n = v[static_cast<std::size_t>(c_f)];
    s.state = can::TestState::Measuring;
    if (!out.samples.empty() && s.t_ns < out.samples.back().t_ns)
      throw fail(fmt::format("t_s {} is before the previous row's", t_s));
    if (!out.samples.empty() && s.t_ns == out.samples.back().t_ns) ++out.repeated_stamps;
    out.samples.push_back(s);
  }
  spread_repeated_stamps(out.samples);
  if (cols.empty()) throw fail("no column header");
  out.calibration = parse_calibration(meta, source + " (# key=value header)");
  if (!timing_given) out.calibration.speed_timing = "instant";
  return out;
}

std::string format_event_csv(const Event& e, const Calibration& c) {
  std::string s = fmt::format("# bench={}\n", can::to_string(c.bench));
  s += fmt::format(
      "# wheel_radius_m={}\n# wheel_load_n={}\n# brake_gain_n_per_bar={}\n# tyre_pressure_bar={}\n",
      c.wheel_radius_m, c.wheel_load_n, c.brake_gain_n_per_bar, c.tyre_pressure_bar);
  s += fmt::format("# speed_kmh={}\n# switch_off_slip_ratio={}\n# speed_timing={}\n", c.speed_kmh,
                   c.switch_off_slip_ratio, c.speed_timing);
  if (c.pressure_filter_s > 0) s += fmt::format("# pressure_filter_s={}\n", c.pressure_filter_s);
  s += fmt::format("# event_id={}\n# end_reason={}\n", e.event_id, e.end_reason);
  const bool force = !e.samples.empty() && std::isfinite(e.samples.front().force_n);
  s += force ? "t_s,v_ref_mps,v_wheel_mps,pressure_bar,force_n\n"
             : "t_s,v_ref_mps,v_wheel_mps,pressure_bar\n";
  const std::int64_t t0 = e.samples.empty() ? 0 : e.samples.front().t_ns;
  for (const Sample& x : e.samples) {
    s += fmt::format("{:.6f},{:.6f},{:.6f},{:.3f}", static_cast<double>(x.t_ns - t0) * 1e-9,
                     x.v_ref_mps, x.v_wheel_mps, x.pressure_bar);
    s += force ? fmt::format(",{:.2f}\n", x.force_n) : "\n";
  }
  return s;
}

}  // namespace brakefit::pipeline
