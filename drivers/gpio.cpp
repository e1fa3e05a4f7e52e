#include "drivers/gpio.hpp"

#include <pthread.h>
#include <sched.h>

#include <fmt/format.h>

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

std::optional<can::LoggedFrame> EncoderFramer::faults_frame(std::uint64_t lost_edges,
                                                            std::int64_t wall_us) {
  const auto now =
      std::make_pair(lost_edges, ref_.illegal_transitions() + wheel_.illegal_transitions());
  if (faults_sent_ && *faults_sent_ == now) return std::nullopt;
  faults_sent_ = now;
  can::EncoderFaultsMsg m;
  m.lost_edges_mod = static_cast<std::uint32_t>(now.first & 0xFFFFFFu);
  m.illegal_transitions_mod = static_cast<std::uint32_t>(now.second & 0xFFFFFFu);
  m.counter = faults_counter_++;
  can::LoggedFrame f;
  f.t_us = wall_us;
  f.iface = cfg_.iface;
  f.frame = can::encode(m);
  return f;
}

std::unique_ptr<EdgeSource> open_edge_source(const GpioConfig& c) {
  return c.uapi == GpioConfig::Uapi::V2 ? open_gpio_v2_edge_source(c) : open_gpiod_edge_source(c);
}

GpioEncoderReader::GpioEncoderReader(const GpioConfig& c, std::unique_ptr<EdgeSource> src,
                                     FrameQueue& out, DriverCounters& counters,
                                     const LiveClock& clock)
    : cfg_(c), src_(std::move(src)), out_(out), counters_(counters), clock_(clock), framer_(c) {
  framer_.seed(src_->levels());
  th_ = std::thread([this] { run(); });
  if (cfg_.reader_rt_priority > 0) {
    // Best effort: without CAP_SYS_NICE (or an RLIMIT_RTPRIO) the thread stays SCHED_OTHER and
    // the kernel FIFO alone has to ride out the delays; scheduling() says which it got.
    sched_param sp{};
    sp.sched_priority = cfg_.reader_rt_priority;
    rt_ok_ = pthread_setschedparam(th_.native_handle(), SCHED_FIFO, &sp) == 0;
  }
}

std::string GpioEncoderReader::scheduling() const {
  if (cfg_.reader_rt_priority <= 0) return "reader not real-time (gpio.reader_rt_priority = 0)";
  return rt_ok_ ? fmt::format("reader real-time (SCHED_FIFO {})", cfg_.reader_rt_priority)
                : fmt::format("reader NOT real-time: SCHED_FIFO {} refused (needs CAP_SYS_NICE)",
                              cfg_.reader_rt_priority);
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
    counters_.lost_edges = src_->lost_edges();
    const std::int64_t t = clock_.now_mono_ns();
    if (t < next_ns) continue;
    auto push = [&](can::LoggedFrame f) {
      if (!out_.push(std::move(f))) ++counters_.queue_drops;
      ++counters_.frames;
    };
    if (auto ff = framer_.faults_frame(src_->lost_edges(), clock_.wall_us(t))) push(std::move(*ff));
    for (auto& f : framer_.frames(clock_.wall_us(t))) push(std::move(f));
    next_ns += period_ns;
    if (next_ns < t) next_ns = t + period_ns;  // fell behind: skip, do not burst
  }
}

}  // namespace brakefit::drivers
