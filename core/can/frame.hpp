#pragma once
// A CAN (or CAN FD) frame as SocketCAN and candump know it, and a frame with its log timestamp.
#include <array>
#include <cstdint>
#include <string>

namespace brakefit::can {

struct Frame {
  std::uint32_t id = 0;   ///< 11- or 29-bit identifier (no flag bits)
  bool extended = false;  ///< 29-bit id
  bool remote = false;    ///< remote transmission request
  bool error = false;     ///< error frame (CAN_ERR_FLAG)
  bool fd = false;        ///< CAN FD frame
  std::uint8_t fd_flags = 0;
  std::uint8_t len = 0;  ///< data length in bytes (remote: the requested length)
  std::array<std::uint8_t, 64> data{};
};

struct LoggedFrame {
  std::int64_t t_us = 0;  ///< log timestamp, microseconds (candump: seconds.microseconds)
  std::string iface = "can0";
  Frame frame;
};

}  // namespace brakefit::can
