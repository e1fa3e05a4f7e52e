#include "core/pipeline/calibration.hpp"

#include <filesystem>

#include "core/toml_reader.hpp"

namespace brakefit::pipeline {

Calibration parse_calibration(std::string_view text, const std::string& source) {
  const toml::table root = parse_toml(text, source);
  TomlReader rd(source);
  rd.check_keys(root, "", {"bench"});
  const toml::table* b = rd.table(root, "", "bench");
  if (!b) rd.fail("bench", "missing [bench] table");
  return calibration_from_table(*b, rd, "bench.");
}

Calibration calibration_from_table(const toml::table& bt, const TomlReader& rd,
                                   const std::string& p) {
  const toml::table* b = &bt;
  rd.check_keys(
      *b, p,
      {"kind", "roller_radius_m", "wheel_radius_m", "fifth_wheel_radius_m", "roller_ppr",
       "wheel_ppr", "fifth_wheel_ppr", "brake_gain_n_per_bar", "wheel_load_n", "tyre_pressure_bar",
       "speed_kmh", "switch_off_slip_ratio", "speed_timing", "pressure_filter_s"});
  Calibration c;
  const std::string kind = rd.string(*b, p, "kind", "roller");
  if (kind == "roller")
    c.bench = can::BenchKind::Roller;
  else if (kind == "ground")
    c.bench = can::BenchKind::Ground;
  else
    rd.fail(p + "kind", "expected 'roller' or 'ground'");
  c.roller_radius_m = rd.number(*b, p, "roller_radius_m", c.roller_radius_m, 0.01, 2.0);
  c.wheel_radius_m = rd.number(*b, p, "wheel_radius_m", c.wheel_radius_m, 0.05, 2.0);
  c.fifth_wheel_radius_m =
      rd.number(*b, p, "fifth_wheel_radius_m", c.fifth_wheel_radius_m, 0.01, 2.0);
  c.roller_ppr = rd.number(*b, p, "roller_ppr", c.roller_ppr, 1, 1e7);
  c.wheel_ppr = rd.number(*b, p, "wheel_ppr", c.wheel_ppr, 1, 1e7);
  c.fifth_wheel_ppr = rd.number(*b, p, "fifth_wheel_ppr", c.fifth_wheel_ppr, 1, 1e7);
  c.brake_gain_n_per_bar =
      rd.number(*b, p, "brake_gain_n_per_bar", c.brake_gain_n_per_bar, 0.001, 1e6);
  c.wheel_load_n = rd.number(*b, p, "wheel_load_n", c.wheel_load_n, 1, 1e6);
  c.tyre_pressure_bar = rd.number(*b, p, "tyre_pressure_bar", c.tyre_pressure_bar, 0.1, 20);
  c.speed_kmh = rd.number(*b, p, "speed_kmh", c.speed_kmh, 0.1, 300);
  c.switch_off_slip_ratio =
      rd.number(*b, p, "switch_off_slip_ratio", c.switch_off_slip_ratio, 0.01, 1.0);
  c.speed_timing = rd.string(*b, p, "speed_timing", c.speed_timing);
  if (c.speed_timing != "frame_mean" && c.speed_timing != "instant")
    rd.fail(p + "speed_timing", "expected 'frame_mean' or 'instant'");
  c.pressure_filter_s = rd.number(*b, p, "pressure_filter_s", c.pressure_filter_s, 0.0, 1.0);
  return c;
}

std::string format_calibration(const Calibration& c) {
  return fmt::format(
      "[bench]\nkind = \"{}\"\nroller_radius_m = {}\nwheel_radius_m = {}\nfifth_wheel_radius_m = "
      "{}\nroller_ppr = {}\n"
      "wheel_ppr = {}\nfifth_wheel_ppr = {}\nbrake_gain_n_per_bar = {}\nwheel_load_n = "
      "{}\ntyre_pressure_bar = {}\n"
      "speed_kmh = {}\nswitch_off_slip_ratio = {}\nspeed_timing = \"{}\"\npressure_filter_s = {}\n",
      can::to_string(c.bench), c.roller_radius_m, c.wheel_radius_m, c.fifth_wheel_radius_m,
      c.roller_ppr, c.wheel_ppr, c.fifth_wheel_ppr, c.brake_gain_n_per_bar, c.wheel_load_n,
      c.tyre_pressure_bar, c.speed_kmh, c.switch_off_slip_ratio, c.speed_timing,
      c.pressure_filter_s);
}

std::string recording_stem(const std::string& log_path) {
  const std::filesystem::path p(log_path);
  return (p.parent_path() / p.stem()).string();
}

}  // namespace brakefit::pipeline
