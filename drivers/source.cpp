#include "drivers/source.hpp"

#include <chrono>
#include <ctime>

namespace brakefit::drivers {

bool FrameQueue::push(can::LoggedFrame f) {
  bool dropped = false;
  {
    std::lock_guard lk(mu_);
    if (q_.size() >= cap_) {
      q_.pop_front();
      dropped = true;
    }
    q_.push_back(std::move(f));
  }
  cv_.notify_one();
  return !dropped;
}

std::optional<can::LoggedFrame> FrameQueue::pop(int timeout_ms) {
  std::unique_lock lk(mu_);
  if (!cv_.wait_for(lk, std::chrono::milliseconds(timeout_ms), [&] { return !q_.empty(); }))
    return std::nullopt;
  can::LoggedFrame f = std::move(q_.front());
  q_.pop_front();
  return f;
}

namespace {
std::int64_t clock_ns(clockid_t id) {
  timespec ts{};
  clock_gettime(id, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}
}  // namespace

LiveClock::LiveClock() : offset_ns_(clock_ns(CLOCK_REALTIME) - clock_ns(CLOCK_MONOTONIC)) {}

std::int64_t LiveClock::now_mono_ns() const {
  return clock_ns(CLOCK_MONOTONIC);
}

}  // namespace brakefit::drivers
