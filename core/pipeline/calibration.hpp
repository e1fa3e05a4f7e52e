#pragma once
// Bench calibration: what the replay pipeline needs to turn encoder counts and pressure into
// speeds, slip and force. Read from a TOML `[bench]` table (a recording's `<stem>.bench.toml`, or
// the daemon's config); strict validation names the key.
#include <string>
#include <string_view>

#include "core/can/layout.hpp"
#include "core/toml_reader.hpp"

namespace brakefit::pipeline {

struct Calibration {
  can::BenchKind bench = can::BenchKind::Roller;
  double roller_radius_m = 0.1;  ///< 200 mm rollers
  double wheel_radius_m = 0.3;   ///< rolling radius of the tested wheel
  double fifth_wheel_radius_m = 0.2;
  double roller_ppr = 1000;  ///< encoder pulses per revolution (x4 counts = 4 * ppr)
  double wheel_ppr = 1000;
  double fifth_wheel_ppr = 1000;
  double brake_gain_n_per_bar = 66.7;  ///< force = gain * pressure (as in the paper)
  double wheel_load_n = 3800;
  double tyre_pressure_bar = 2.2;
  double speed_kmh = 5.0;  ///< roller set speed or ground start speed
  double switch_off_slip_ratio = 0.27;
  /// How the speeds were sampled: "frame_mean" (an encoder frame's speed is the mean since the
  /// previous frame, as the project's encoder frames and its own exports), or "instant" (an event
  /// CSV from elsewhere that does not say: taken at the stamp).
  std::string speed_timing = "frame_mean";
  /// A first-order filter the tester applied to the pressure channel before export (its time
  /// constant, s; 0: none). The diagnosis undoes a declared filter; an undeclared one shows as
  /// a late force channel (time_offset).
  double pressure_filter_s = 0.0;
};

Calibration parse_calibration(std::string_view toml_text, const std::string& source);
/// The `[bench]` table of a larger file (the daemon's config); keys are named "<prefix>key".
Calibration calibration_from_table(const toml::table& bench, const TomlReader& rd,
                                   const std::string& prefix);
std::string format_calibration(const Calibration& c);
/// "dir/name.log" -> "dir/name": a recording's sidecars are <stem>.bench.toml (its calibration)
/// and <stem>.truth.json. Path text only, no I/O.
std::string recording_stem(const std::string& log_path);

}  // namespace brakefit::pipeline
