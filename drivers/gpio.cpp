#include "drivers/gpio.hpp"

#include <algorithm>

namespace brakefit::drivers {

void EncoderFramer::seed(const std::array<bool, 4>& lv) {
  ref_.seed(lv[kRefA], lv[kRefB]);
  wheel_.seed(lv[kWheelA], lv[kWheelB]);
}

void EncoderFramer::process(std::vector<EdgeEvent> events) {
  // Each line's events are in order; lines are merged by timestamp (stable for equal times).
  std::stable_sort(events.begin(), events.end(),
                   [](const EdgeEvent& a, const EdgeEvent& b) { return a.t_ns < b.t_ns; });
  for (const EdgeEvent& e : events) {
    QuadratureDecoder& d = e.line <= kRefB ? ref_ : wheel_;
    d.edge(e.line == kRefB || e.line == kWheelB, e.rising, e.t_ns);
  }
}

std::array<can::LoggedFrame, 2> EncoderFramer::frames(std::int64_t wall_us) {
  auto make = [&](const QuadratureDecoder& d, can::Channel ch) {
    can::EncoderMsg m;
    m.channel = ch;
    m.count_x4_mod = static_cast<std::uint32_t>(d.count_x4()) & 0xFFFFFFu;
    m.edge_time_us = static_cast<std::uint32_t>(d.last_edge_ns() / 1000);
    m.counter = counter_;
    can::LoggedFrame f;
    f.t_us = wall_us;
    f.iface = cfg_.iface;
    f.frame = can::encode(m);
    return f;
  };
  auto out = std::array<can::LoggedFrame, 2>{
      make(ref_, cfg_.ground ? can::Channel::FifthWheel : can::Channel::Roller),
      make(wheel_, can::Channel::Wheel)};
  ++counter_;
  return out;
}

GpioEncoderReader::GpioEncoderReader(const GpioConfig& c, std::unique_ptr<EdgeSource> src,
                                     FrameQueue& out, DriverCounters& counters,
                                     const LiveClock& clock)
    : cfg_(c), src_(std::move(src)), out_(out), counters_(counters), clock_(clock), framer_(c) {
  framer_.seed(src_->levels());
  th_ = std::thread([this] { run(); });
}

GpioEncoderReader::~GpioEncoderReader() {
  stop_ = true;
  if (th_.joinable()) th_.join();
}

void GpioEncoderReader::run() {
  const std::int64_t period_ns = static_cast<std::int64_t>(cfg_.frame_period_ms) * 1'000'000;
  std::int64_t next_ns = clock_.now_mono_ns() + period_ns;
  while (!stop_) {
    const std::int64_t now = clock_.now_mono_ns();
    // Rounded up (at least 1 ms): a zero timeout would make poll spin until the frame is due.
    const int wait_ms =
        static_cast<int>(std::max<std::int64_t>(1, (next_ns - now + 999'999) / 1'000'000));
    framer_.process(src_->wait(wait_ms));  // blocks in poll, never busy-waits
    counters_.illegal_transitions =
        framer_.ref().illegal_transitions() + framer_.wheel().illegal_transitions();
    const std::int64_t t = clock_.now_mono_ns();
    if (t < next_ns) continue;
    for (auto& f : framer_.frames(clock_.wall_us(t))) {
      if (!out_.push(std::move(f))) ++counters_.queue_drops;
      ++counters_.frames;
    }
    next_ns += period_ns;
    if (next_ns < t) next_ns = t + period_ns;  // fell behind: skip, do not burst
  }
}

}  // namespace brakefit::drivers
