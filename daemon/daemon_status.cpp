// The daemon's status: which channels are missing, the status flags, the status registers and
// systemd's STATUS= line.
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <systemd/sd-daemon.h>

#include <algorithm>
#include <cmath>

#include "daemon/daemon.hpp"

namespace brakefit::daemon {

bool Daemon::channel_missing(int ch, Clock::time_point now) const {
  const auto timeout = std::chrono::duration<double>(cfg_.sensor_timeout_s);
  const auto last = seen_[static_cast<std::size_t>(ch)].value_or(start_);
  return now - last > timeout;
}

std::uint16_t Daemon::status_flags(Clock::time_point now) const {
  std::uint16_t f = kStatusRunning;
  if (source_finished_) f |= kStatusSourceFinished;
  if (!source_finished_) {
    if (channel_missing(0, now)) f |= kStatusRefEncoderMissing;
    if (channel_missing(1, now)) f |= kStatusWheelEncoderMissing;
    if (channel_missing(2, now)) f |= kStatusPressureMissing;
  }
  if (pipeline_->event_active()) f |= kStatusEventActive;
  if (store_->degraded()) f |= kStatusStoreDegraded;
  if (store_error_) f |= kStatusStoreError;
  if (pending_->size() > 0) f |= kStatusEventsWaiting;
  if (recorder_error_) f |= kStatusRecorderError;
  if (cfg_.modbus_tcp.writable) f |= kStatusWritable;
  return f;
}

void Daemon::post_status(Clock::time_point now) {
  RegisterWrites w;
  auto& c = source_->counters();
  const auto& st = pipeline_->sample_stats();
  w.u16("status_flags", status_flags(now));
  w.u32("uptime_s", static_cast<std::uint32_t>(
                        std::chrono::duration_cast<std::chrono::seconds>(now - start_).count()));
  w.u32("frames", static_cast<std::uint32_t>(c.frames.load()));
  w.u32("events_finished", static_cast<std::uint32_t>(events_finished_));
  w.u32("events_flagged", static_cast<std::uint32_t>(events_flagged_));
  w.u32("illegal_transitions", static_cast<std::uint32_t>(c.illegal_transitions.load()));
  w.u32("rtu_timeouts", static_cast<std::uint32_t>(c.rtu_timeouts.load()));
  w.u32("rtu_reconnects", static_cast<std::uint32_t>(c.rtu_reconnects.load()));
  w.u32("counter_gaps", static_cast<std::uint32_t>(st.counter_gaps));
  w.u32("unknown_ids", static_cast<std::uint32_t>(st.unknown_ids));
  w.u32("encoder_resyncs", static_cast<std::uint32_t>(st.encoder_resyncs));
  w.u32("queue_drops", static_cast<std::uint32_t>(c.queue_drops.load()));
  w.u32("lost_edges", static_cast<std::uint32_t>(c.lost_edges.load()));
  w.u32("can_rx_dropped", static_cast<std::uint32_t>(c.can_rx_dropped.load()));
  w.u16("events_waiting",
        static_cast<std::uint16_t>(std::min<std::size_t>(pending_->size(), 65535)));
  w.u16("events_spilled",
        static_cast<std::uint16_t>(std::min<std::size_t>(pending_->spilled(), 65535)));
  w.u32("store_failures", static_cast<std::uint32_t>(store_failures_));
  w.u32("events_lost", static_cast<std::uint32_t>(pending_->lost()));
  const double nan = std::nan("");
  // After a replay ends nothing is live: the last sample is history, not a reading.
  const auto& s = source_finished_ ? std::optional<pipeline::Sample>() : pipeline_->last_sample();
  w.f32("v_ref_mps", s ? s->v_ref_mps : nan);
  w.f32("v_wheel_mps", s ? s->v_wheel_mps : nan);
  w.f32("slip_ratio", s ? pipeline::slip_ratio(*s) : nan);
  w.f32("pressure_bar", s ? s->pressure_bar : nan);
  w.f32("force_n", s ? s->force_n : nan);
  server_->post(std::move(w));
}

void Daemon::notify_status() {
  std::vector<std::string> missing;
  const auto f = status_flags(Clock::now());
  if (f & kStatusRefEncoderMissing) missing.push_back("reference encoder");
  if (f & kStatusWheelEncoderMissing) missing.push_back("wheel encoder");
  if (f & kStatusPressureMissing) missing.push_back("pressure");
  std::string s = fmt::format(
      "{} events; {}; sensors {}{}{}{}", events_finished_, source_->describe(),
      missing.empty() ? "ok" : fmt::format("missing: {}", fmt::join(missing, ", ")),
      store_->degraded() ? "; store degraded (samples not stored)" : "",
      pending_->size() ? fmt::format("; {} event(s) waiting for the store", pending_->size()) : "",
      source_finished_ ? "; replay finished" : "");
  if (s == last_status_) return;
  last_status_ = s;
  sd_notify(0, ("STATUS=" + s).c_str());
}

}  // namespace brakefit::daemon
