#pragma once
// The two quadrature encoders (roller or fifth wheel as the reference, and the tested wheel) on
// GPIO lines. An EdgeSource is the seam: the libgpiod 1.6 adapter (GpiodEdgeSource) in production,
// a scripted source in tests. A reader thread blocks in the source's poll, decodes x4, and every
// frame period sends the counts and last-edge times as encoder frames (ids 0x100/0x102 and 0x101),
// the same frames a CAN bench sends.
#include <array>
#include <memory>
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
};

struct GpioConfig {
  std::string chip = "gpiochip0";
  std::array<unsigned, 4> offsets{0, 1, 2, 3};  ///< EncoderLine order
  bool ground = false;                          ///< reference is a fifth wheel (id 0x102)
  int frame_period_ms = 1;
  std::string iface = "gpio0";  ///< interface name written in recorded logs
};

/// Opens the chip and requests both-edge events on the four lines; throws SourceError naming the
/// chip or line when absent.
std::unique_ptr<EdgeSource> open_gpiod_edge_source(const GpioConfig& c);

/// Pure part of the GPIO path: merges events of all lines by timestamp, decodes, makes frames.
class EncoderFramer {
 public:
  explicit EncoderFramer(const GpioConfig& c) : cfg_(c) {}
  void seed(const std::array<bool, 4>& levels);
  void process(std::vector<EdgeEvent> events);
  /// Reference then wheel encoder frame, stamped wall_us.
  std::array<can::LoggedFrame, 2> frames(std::int64_t wall_us);
  const QuadratureDecoder& ref() const { return ref_; }
  const QuadratureDecoder& wheel() const { return wheel_; }

 private:
  GpioConfig cfg_;
  QuadratureDecoder ref_, wheel_;
  std::uint8_t counter_ = 0;
};

/// Reader thread over an EdgeSource pushing encoder frames into a queue.
class GpioEncoderReader {
 public:
  GpioEncoderReader(const GpioConfig& c, std::unique_ptr<EdgeSource> src, FrameQueue& out,
                    DriverCounters& counters, const LiveClock& clock);
  ~GpioEncoderReader();
  GpioEncoderReader(const GpioEncoderReader&) = delete;
  GpioEncoderReader& operator=(const GpioEncoderReader&) = delete;

 private:
  void run();
  GpioConfig cfg_;
  std::unique_ptr<EdgeSource> src_;
  FrameQueue& out_;
  DriverCounters& counters_;
  const LiveClock& clock_;
  EncoderFramer framer_;
  std::atomic<bool> stop_{false};
  std::thread th_;
};

}  // namespace brakefit::drivers
