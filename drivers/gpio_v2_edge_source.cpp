// The GPIO character device's v2 uAPI (linux/gpio.h, kernel >= 5.10), used directly because
// libgpiod 1.6 speaks only v1: one request for the four lines, one kernel FIFO for all of them
// (events arrive already merged in edge order) whose size the request sets (event_buffer_size, up
// to 16 per line by default, 1024 at most), and sequence numbers on every event, so an edge the
// kernel dropped (FIFO overflow, or two edges before the IRQ thread ran) is counted, never silent.
#include <fcntl.h>
#include <fmt/format.h>
#include <linux/gpio.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "drivers/gpio.hpp"

namespace brakefit::drivers {

namespace {

class GpioV2EdgeSource final : public EdgeSource {
 public:
  explicit GpioV2EdgeSource(const GpioConfig& c) : offsets_(c.offsets) {
    const std::string path = c.chip.find('/') == std::string::npos ? "/dev/" + c.chip : c.chip;
    if (!std::filesystem::exists(path))
      throw SourceError(fmt::format("gpio: no gpiochip '{}' ({} does not exist)", c.chip, path));
    const int chip = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (chip < 0)
      throw SourceError(fmt::format("gpio: cannot open {}: {}", path, std::strerror(errno)));
    gpio_v2_line_request req{};
    for (unsigned i = 0; i < 4; ++i) req.offsets[i] = c.offsets[i];
    req.num_lines = 4;
    req.config.flags =
        GPIO_V2_LINE_FLAG_INPUT | GPIO_V2_LINE_FLAG_EDGE_RISING | GPIO_V2_LINE_FLAG_EDGE_FALLING;
    req.event_buffer_size = static_cast<std::uint32_t>(c.event_buffer_size);
    std::strncpy(req.consumer, "brakefitd", sizeof req.consumer - 1);
    const int rc = ::ioctl(chip, GPIO_V2_GET_LINE_IOCTL, &req);
    const int err = errno;
    ::close(chip);
    if (rc < 0)
      throw SourceError(fmt::format("gpio: cannot request lines {} on '{}' (v2 uAPI): {}{}",
                                    fmt::join(c.offsets, ","), c.chip, std::strerror(err),
                                    err == ENOTTY || err == EINVAL
                                        ? " (a kernel before 5.10 has no v2 uAPI: set gpio.uapi "
                                          "= \"v1\")"
                                        : ""));
    fd_ = req.fd;
  }
  ~GpioV2EdgeSource() override {
    if (fd_ >= 0) ::close(fd_);
  }
  GpioV2EdgeSource(const GpioV2EdgeSource&) = delete;
  GpioV2EdgeSource& operator=(const GpioV2EdgeSource&) = delete;

  std::array<bool, 4> levels() override {
    gpio_v2_line_values v{};
    v.mask = 0xF;
    if (::ioctl(fd_, GPIO_V2_LINE_GET_VALUES_IOCTL, &v) < 0)
      throw SourceError(fmt::format("gpio: cannot read line values: {}", std::strerror(errno)));
    return {(v.bits & 1u) != 0, (v.bits & 2u) != 0, (v.bits & 4u) != 0, (v.bits & 8u) != 0};
  }

  std::vector<EdgeEvent> wait(int timeout_ms) override {
    std::vector<EdgeEvent> out;
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, timeout_ms) <= 0 || !(p.revents & POLLIN)) return out;
    std::array<gpio_v2_line_event, 64> buf{};
    for (;;) {
      const ssize_t n = ::read(fd_, buf.data(), sizeof buf);
      if (n <= 0) break;
      const auto k = static_cast<std::size_t>(n) / sizeof(gpio_v2_line_event);
      for (std::size_t i = 0; i < k; ++i) {
        const auto& ev = buf[i];
        // seqno counts every edge the request saw, in order: a jump is edges the kernel lost.
        if (last_seqno_ != 0 && ev.seqno > last_seqno_ + 1) lost_ += ev.seqno - last_seqno_ - 1;
        last_seqno_ = ev.seqno;
        unsigned line = 0;
        while (line < 4 && offsets_[line] != ev.offset) ++line;
        if (line == 4) continue;
        out.push_back({line, ev.id == GPIO_V2_LINE_EVENT_RISING_EDGE,
                       static_cast<std::int64_t>(ev.timestamp_ns)});
      }
      if (k < buf.size()) break;
      pollfd again{fd_, POLLIN, 0};
      if (::poll(&again, 1, 0) <= 0) break;
    }
    return out;
  }

  std::uint64_t lost_edges() const override { return lost_; }

 private:
  std::array<unsigned, 4> offsets_;
  int fd_ = -1;
  std::uint32_t last_seqno_ = 0;
  std::uint64_t lost_ = 0;
};

}  // namespace

std::unique_ptr<EdgeSource> open_gpio_v2_edge_source(const GpioConfig& c) {
  return std::make_unique<GpioV2EdgeSource>(c);
}

}  // namespace brakefit::drivers
