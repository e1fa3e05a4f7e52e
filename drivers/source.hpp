#pragma once
// What every source (gpio + modbus-rtu, socketcan, replay) gives the daemon: bench CAN frames in
// the layout of config/brakefit.dbc, so the one pipeline, the recorder and the replay all see the
// same stream. Live drivers run reader threads that push into a FrameQueue.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>

#include "core/can/frame.hpp"

namespace brakefit::drivers {

/// A configured source that is absent or broken (no gpiochip, serial port, CAN interface...).
class SourceError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Driver counters, read by the daemon for its status registers.
struct DriverCounters {
  std::atomic<std::uint64_t> frames{0};
  std::atomic<std::uint64_t> queue_drops{0};
  std::atomic<std::uint64_t> illegal_transitions{0};
  std::atomic<std::uint64_t> lost_edges{0};      ///< v2 uAPI sequence-number gaps
  std::atomic<std::uint64_t> can_rx_dropped{0};  ///< SO_RXQ_OVFL: frames the kernel dropped
  std::atomic<std::uint64_t> rtu_reads{0};
  std::atomic<std::uint64_t> rtu_timeouts{0};
  std::atomic<std::uint64_t> rtu_errors{0};
  std::atomic<std::uint64_t> rtu_reconnects{0};
  std::atomic<std::uint64_t> can_errors{0};
};

class FrameSource {
 public:
  virtual ~FrameSource() = default;
  /// The next frame, waiting at most timeout_ms; std::nullopt on timeout or when finished.
  virtual std::optional<can::LoggedFrame> next(int timeout_ms) = 0;
  /// True when no frame will ever come again (end of a replay).
  virtual bool finished() const { return false; }
  virtual std::string describe() const = 0;
  DriverCounters& counters() { return counters_; }

 protected:
  DriverCounters counters_;
};

/// Bounded multi-producer queue; a full queue drops the oldest frame and counts it.
class FrameQueue {
 public:
  explicit FrameQueue(std::size_t capacity = 65536) : cap_(capacity) {}
  /// Returns false when a frame had to be dropped.
  bool push(can::LoggedFrame f);
  std::optional<can::LoggedFrame> pop(int timeout_ms);

 private:
  std::mutex mu_;
  std::condition_variable cv_;
  std::deque<can::LoggedFrame> q_;
  std::size_t cap_;
};

/// Microseconds on the wall clock for live frames: CLOCK_MONOTONIC plus the offset measured at
/// start, so recorded logs carry wall-clock times that never jump.
class LiveClock {
 public:
  LiveClock();
  std::int64_t now_mono_ns() const;
  std::int64_t wall_us(std::int64_t mono_ns) const { return (mono_ns + offset_ns_) / 1000; }

 private:
  std::int64_t offset_ns_;
};

}  // namespace brakefit::drivers
