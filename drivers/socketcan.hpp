#pragma once
// A live raw CAN socket: kernel filters for the bench ids, SO_TIMESTAMP receive times. The socket
// is the seam: tests hand in one end of a socketpair(AF_UNIX, SOCK_SEQPACKET) carrying struct
// can_frame records (this machine's kernel has no SocketCAN). Parsing the records is pure.
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "drivers/source.hpp"

namespace brakefit::drivers {

/// A struct can_frame (16 bytes) or canfd_frame (72 bytes) record -> Frame; std::nullopt for a
/// record of another size.
std::optional<can::Frame> frame_from_record(const std::uint8_t* data, std::size_t n);
/// Frame -> struct can_frame record (16 bytes; tests and tools).
std::vector<std::uint8_t> record_from_frame(const can::Frame& f);

class CanSocket {
 public:
  /// socket(PF_CAN, SOCK_RAW, CAN_RAW) bound to iface with filters for ids; throws SourceError
  /// naming the interface (or saying SocketCAN is missing from the kernel).
  static CanSocket open(const std::string& iface, const std::vector<std::uint32_t>& ids);
  /// Adopts an already connected datagram fd (SO_TIMESTAMP is enabled on it).
  CanSocket(int fd, std::string iface);
  CanSocket(CanSocket&& o) noexcept;
  CanSocket& operator=(CanSocket&&) = delete;
  CanSocket(const CanSocket&) = delete;
  ~CanSocket();
  /// One frame, waiting up to timeout_ms (poll); stamped with SO_TIMESTAMP when present.
  std::optional<can::LoggedFrame> read(int timeout_ms, DriverCounters* counters = nullptr);
  int fd() const { return fd_; }

 private:
  int fd_ = -1;
  std::string iface_;
};

/// A reader thread drains the socket into a FrameQueue, so the kernel's receive queue (a few
/// hundred frames at the default net.core.rmem_max) is emptied while the pipeline fits an event;
/// what the kernel still drops is counted (SO_RXQ_OVFL -> can_rx_dropped).
class SocketCanSource final : public FrameSource {
 public:
  SocketCanSource(CanSocket s, std::string iface);
  ~SocketCanSource() override;
  SocketCanSource(const SocketCanSource&) = delete;
  SocketCanSource& operator=(const SocketCanSource&) = delete;
  std::optional<can::LoggedFrame> next(int timeout_ms) override { return q_.pop(timeout_ms); }
  std::string describe() const override { return "socketcan " + iface_; }

 private:
  CanSocket sock_;
  std::string iface_;
  FrameQueue q_;
  std::atomic<bool> stop_{false};
  std::thread th_;
};

}  // namespace brakefit::drivers
