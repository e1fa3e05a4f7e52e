#pragma once
// Brake event detection on the sample stream: an event starts when the pressure rises past a
// threshold and ends at the switch-off slip (roller), wheel lock, release of the pedal, the
// reference stopping, or a sensor timeout (aborted). The switch-off and lock decisions use the
// slip filtered over the last end_filter_s (the mean of the samples in that window), not one raw
// sample: one noisy or quantised sample must not end a stop. An event file (one exported event)
// ends at its last row: finished, end_of_file. Too short or aborted events are flagged and not
// fitted.
#include <deque>
#include <optional>
#include <string>
#include <vector>

#include "core/curve.hpp"
#include "core/pipeline/calibration.hpp"
#include "core/pipeline/samples.hpp"

namespace brakefit::pipeline {

struct EventSettings {
  double start_pressure_bar = 2.0;
  double release_pressure_bar = 1.0;
  double lock_slip_ratio = 0.95;
  double min_ref_speed_mps = 0.3;
  /// A station's export may sample at 50 Hz: a fast ground stop there holds 8-11 samples from the
  /// pressure's rise to the lock, its linear region and its peak. Below this many (the fewest a
  /// curve fit takes) the event is too_short.
  std::size_t min_points = 8;
  /// A real ground stop is short: at 250 bar/s from 30 km/h a light wheel locks 0.18 s after the
  /// pressure rise (generator B); 0.2 s refused such events as too short.
  double min_duration_s = 0.1;
  double sensor_timeout_s = 0.1;  ///< a gap between samples longer than this aborts the event
  /// Switch-off and lock compare the mean slip of the samples within this window (5 ms: five
  /// samples at 1 kHz) with their thresholds.
  double end_filter_s = 0.005;
  /// The samples this long before an event's start are kept with it (Event::lead_in): the rise
  /// from rest, which the start threshold cuts, tells a brake's dead zone from a slip offset.
  /// 1 s reaches rest on ramps from 2 bar/s; 0.15 s did so only above 12 bar/s (half of
  /// generator B's roller runs started at 2 bar, the dead zone cut: read 16 % short).
  double lead_in_s = 1.0;
  /// An event running this long ends, flagged aborted (max_length): a stuck pressure or a test
  /// never switched off would otherwise grow without end. A slow 2 bar/s roller ramp to lock
  /// lasts under 15 s.
  double max_event_s = 60.0;
  /// Plausible readings: a sample outside these (or not finite) ends a running event, flagged
  /// aborted (implausible_data), and never starts one: no implausible reading is fitted.
  double max_speed_mps = 100.0;   ///< both speeds; 360 km/h
  double min_speed_mps = -0.5;    ///< an encoder read backwards beyond this is a fault
  double max_pressure_bar = 400;  ///< hydraulic brake lines stay under 250 bar, air brakes 10
  double min_pressure_bar = -5;   ///< a transducer's offset reads a little below zero
};

struct Event {
  int event_id = 0;
  can::BenchKind bench = can::BenchKind::Roller;
  std::int64_t t_start_ns = 0;
  std::int64_t t_end_ns = 0;
  std::string end_reason;  ///< switch_off_slip, wheel_lock, release, stopped, sensor_timeout,
                           ///< end_of_data (aborted), end_of_file (an event file's last row:
                           ///< finished), max_length and implausible_data (aborted)
  /// too_short, aborted, sensor_fault; edges_lost (the GPIO reader lost edges during the event:
  /// still fitted, the speeds around the loss are suspect)
  std::vector<std::string> flags;
  std::string note;  ///< what ended an aborted event, where the reason alone does not say
  std::vector<Sample> samples;
  /// The samples of the lead_in_s before the start (pressure under start_pressure_bar): for
  /// the gap diagnosis, not fitted, not stored.
  std::vector<Sample> lead_in;
  std::uint64_t encoder_faults_at_start = 0;
  bool fittable() const {
    for (const auto& f : flags)
      if (f != "edges_lost") return false;
    return true;
  }
};

inline double slip_ratio(const Sample& s) {
  return s.v_ref_mps > 0 ? 1.0 - s.v_wheel_mps / s.v_ref_mps : 0.0;
}

/// Whether every reading of the sample lies in the settings' plausible ranges; else what is not,
/// with its value.
std::optional<std::string> implausible(const Sample& s, const EventSettings& set);

class EventDetector {
 public:
  EventDetector(const Calibration& c, const EventSettings& s) : cal_(c), set_(s) {}
  /// Returns an event when this sample finished one.
  std::optional<Event> feed(const Sample& s);
  /// End of data: a running event is returned, flagged aborted (a log cut mid-stop).
  std::optional<Event> finish();
  /// End of an event file (one exported event): its last row ends a running event, which is
  /// finished (end_of_file), not aborted.
  std::optional<Event> finish_file();
  /// Ends a running event now, flagged aborted (sensor timeout seen by the daemon's clock,
  /// operator abort, shutdown).
  std::optional<Event> abort(const std::string& reason);
  /// Allows a new event without waiting for the pedal release (operator command).
  void arm() { armed_ = true; }
  bool active() const { return cur_.has_value(); }

 private:
  std::optional<Event> close(const std::string& reason, bool aborted);
  Calibration cal_;
  EventSettings set_;
  std::optional<Event> cur_;
  int next_id_ = 1;
  bool armed_ = true;  ///< a new event needs the pedal released first
  std::int64_t last_t_ns_ = 0;
  std::deque<std::pair<std::int64_t, double>> recent_slip_;  ///< (t_ns, slip) within end_filter_s
  std::deque<Sample> before_;  ///< the samples of the last lead_in_s while no event runs
};

enum class ForceSource { Pressure, Tester };

/// Slip (Eq. 1) and force of the event's samples with a valid reference speed and the brake
/// applied: force = brake_gain_n_per_bar * pressure_bar, or the tester's reading.
Curve event_curve(const Event& e, const Calibration& c, const EventSettings& s, ForceSource source);

}  // namespace brakefit::pipeline
