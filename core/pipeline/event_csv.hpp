#pragma once
// Event CSV: one brake event with its bench metadata, so data from other benches can be analysed.
//   # bench=roller
//   # wheel_radius_m=0.3  (also wheel_load_n, brake_gain_n_per_bar, tyre_pressure_bar, speed_kmh,
//   ...; speed_timing=frame_mean|instant, absent: instant; pressure_filter_s, a declared
//   first-order filter of the pressure channel)
//   t_s,v_ref_mps,v_wheel_mps,pressure_bar[,force_n]
#include <string>
#include <string_view>
#include <vector>

#include "core/pipeline/calibration.hpp"
#include "core/pipeline/events.hpp"

namespace brakefit::pipeline {

struct EventCsv {
  Calibration calibration;
  std::vector<Sample> samples;
  bool has_force = false;
  /// Rows that repeated the previous row's time stamp (a tester's export at a coarse clock): they
  /// keep their order and are spread evenly up to the next stamp.
  std::size_t repeated_stamps = 0;
};

/// Throws InputError "SOURCE:LINE: ..." (unknown or malformed keys, missing columns, bad numbers,
/// a time stamp before the previous one). Rows sharing a stamp are spread evenly up to the next.
EventCsv parse_event_csv(std::string_view text, const std::string& source);
std::string format_event_csv(const Event& e, const Calibration& c);
/// The event settings for one exported event: an export is one event its tester already cut, so
/// where its pressures stay low (air brakes: 8 bar, the wheel at its peak by 2-4 bar) the start
/// and release pressures are scaled down to a tenth of its largest pressure; a hydraulic
/// export (tens of bar) keeps the configured ones.
EventSettings event_csv_settings(const EventCsv& ev, EventSettings configured);
/// True when the text looks like an event CSV rather than a candump log.
bool looks_like_event_csv(std::string_view text);

}  // namespace brakefit::pipeline
