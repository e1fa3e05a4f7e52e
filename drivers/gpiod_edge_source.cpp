// The thin libgpiod 1.6 adapter: one request for the four lines with both-edge events, poll on
// their fds, read the events. Everything else (decoding, framing) is tested through EdgeSource.
#include <fmt/format.h>
#include <poll.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <gpiod.hpp>

#include "drivers/gpio.hpp"

namespace brakefit::drivers {

namespace {

class GpiodEdgeSource final : public EdgeSource {
 public:
  explicit GpiodEdgeSource(const GpioConfig& c) {
    const std::string path = c.chip.find('/') == std::string::npos ? "/dev/" + c.chip : c.chip;
    if (!std::filesystem::exists(path))
      throw SourceError(fmt::format("gpio: no gpiochip '{}' ({} does not exist)", c.chip, path));
    try {
      chip_ = gpiod::chip(path, gpiod::chip::OPEN_BY_PATH);
      std::vector<unsigned> offs(c.offsets.begin(), c.offsets.end());
      lines_ = chip_.get_lines(offs);
      lines_.request({"brakefitd", gpiod::line_request::EVENT_BOTH_EDGES, 0});
    } catch (const std::exception& e) {
      throw SourceError(fmt::format("gpio: cannot request lines {} on '{}': {}",
                                    fmt::join(c.offsets, ","), c.chip, e.what()));
    }
  }
  std::array<bool, 4> levels() override {
    const auto v = lines_.get_values();
    return {v[0] != 0, v[1] != 0, v[2] != 0, v[3] != 0};
  }
  std::vector<EdgeEvent> wait(int timeout_ms) override {
    std::array<pollfd, 4> fds{};
    for (unsigned i = 0; i < 4; ++i) fds[i] = {lines_[i].event_get_fd(), POLLIN, 0};
    std::vector<EdgeEvent> out;
    if (::poll(fds.data(), fds.size(), timeout_ms) <= 0) return out;
    for (unsigned i = 0; i < 4; ++i) {
      if (!(fds[i].revents & POLLIN)) continue;
      for (const auto& ev : lines_[i].event_read_multiple())
        out.push_back({i, ev.event_type == gpiod::line_event::RISING_EDGE,
                       static_cast<std::int64_t>(ev.timestamp.count())});
    }
    return out;
  }

 private:
  gpiod::chip chip_;
  gpiod::line_bulk lines_;
};

}  // namespace

std::unique_ptr<EdgeSource> open_gpiod_edge_source(const GpioConfig& c) {
  return std::make_unique<GpiodEdgeSource>(c);
}

}  // namespace brakefit::drivers
