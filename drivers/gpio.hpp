#pragma once
// The two quadrature encoders (roller or fifth wheel as the reference, and the tested wheel) on
// GPIO lines. An EdgeSource is the seam: the libgpiod 1.6 adapter (GpiodEdgeSource) in production,
// a scripted source in tests. A reader thread blocks in the source's poll, decodes x4, and every
// frame period sends the counts and last-edge times as encoder frames (ids 0x100/0x102 and 0x101),
// the same frames a CAN bench sends.
#include <array>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "core/can/layout.hpp"
#include "drivers/quadrature.hpp"
#include "drivers/source.hpp"

namespace brakefit::drivers {

/// Line indices of an edge source: reference encoder A/B, wheel encoder A/B.
enum EncoderLine : unsigned { kRefA = 0, kRefB = 1, kWheelA = 2, kWheelB = 3 };

struct EdgeEvent {
  unsigned line = 0;  ///< EncoderLine
  bool rising = false;
  std::int64_t t_ns = 0;  ///< CLOCK_MONOTONIC
};

class EdgeSource {
 public:
  virtual ~EdgeSource() = default;
  /// Current levels of the four lines (seeds the decoders).
  virtual std::array<bool, 4> levels() = 0;
  /// Blocks up to timeout_ms for events; returns those that arrived (possibly none).
  virtual std::vector<EdgeEvent> wait(int timeout_ms) = 0;
  /// Edges the kernel is known to have dropped (v2 sequence gaps); 0 where it cannot tell (v1).
  virtual std::uint64_t lost_edges() const { return 0; }
};

struct GpioConfig {
  std::string chip = "gpiochip0";
  std::array<unsigned, 4> offsets{0, 1, 2, 3};  ///< EncoderLine order
  bool ground = false;                          ///< reference is a fifth wheel (id 0x102)
  int frame_period_ms = 1;
  std::string iface = "gpio0";  ///< interface name written in recorded logs
  enum class Uapi { V1, V2 } uapi = Uapi::V2;
  int event_buffer_size = 1024;  ///< v2: the request's kernel FIFO (events, all four lines)
  int reader_rt_priority = 0;    ///< SCHED_FIFO priority of the reader thread (0: not real-time)
};

/// Opens the chip and requests both-edge events on the four lines with libgpiod 1.6 (the v1 uAPI:
/// a 16-event FIFO per line, overflow silent); throws SourceError naming the chip or line.
std::unique_ptr<EdgeSource> open_gpiod_edge_source(const GpioConfig& c);
/// The same through the kernel's v2 uAPI (gpio_v2_edge_source.cpp): one FIFO of
/// event_buffer_size events, sequence numbers that count dropped edges.
std::unique_ptr<EdgeSource> open_gpio_v2_edge_source(const GpioConfig& c);
/// The one GpioConfig::uapi names.
std::unique_ptr<EdgeSource> open_edge_source(const GpioConfig& c);

/// Pure part of the GPIO path: merges events of all lines by timestamp, decodes, makes frames.
class EncoderFramer {
 public:
  explicit EncoderFramer(const GpioConfig& c) : cfg_(c) {}
  void seed(const std::array<bool, 4>& levels);
  void process(std::vector<EdgeEvent> events);
  /// Reference then wheel encoder frame, stamped wall_us.
  std::array<can::LoggedFrame, 2> frames(std::int64_t wall_us);
  /// An ENCODER_FAULTS frame when the lost-edge or illegal-transition totals changed since the
  /// last one (and the first time it is asked), else std::nullopt.
  std::optional<can::LoggedFrame> faults_frame(std::uint64_t lost_edges, std::int64_t wall_us);
  const QuadratureDecoder& ref() const { return ref_; }
  const QuadratureDecoder& wheel() const { return wheel_; }

 private:
  GpioConfig cfg_;
  QuadratureDecoder ref_, wheel_;
  std::uint8_t counter_ = 0;
  std::optional<std::pair<std::uint64_t, std::uint64_t>> faults_sent_;
  std::uint8_t faults_counter_ = 0;
};

/// Reader thread over an EdgeSource pushing encoder frames into a queue.
class GpioEncoderReader {
 public:
  GpioEncoderReader(const GpioConfig& c, std::unique_ptr<EdgeSource> src, FrameQueue& out,
                    DriverCounters& counters, const LiveClock& clock);
  ~GpioEncoderReader();
  GpioEncoderReader(const GpioEncoderReader&) = delete;
  GpioEncoderReader& operator=(const GpioEncoderReader&) = delete;
  /// "reader real-time (SCHED_FIFO N)" or why it is not.
  std::string scheduling() const;

 private:
  void run();
  GpioConfig cfg_;
  std::unique_ptr<EdgeSource> src_;
  FrameQueue& out_;
  DriverCounters& counters_;
  const LiveClock& clock_;
  EncoderFramer framer_;
  std::atomic<bool> stop_{false};
  bool rt_ok_ = false;  ///< SCHED_FIFO granted (set once by the constructor)
  std::thread th_;
};

}  // namespace brakefit::drivers
