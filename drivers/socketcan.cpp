#include "drivers/socketcan.hpp"

#include <fmt/format.h>
#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>

namespace brakefit::drivers {

std::optional<can::Frame> frame_from_record(const std::uint8_t* data, std::size_t n) {
  if (n != sizeof(can_frame) && n != sizeof(canfd_frame)) return std::nullopt;
  canfd_frame raw{};
  std::memcpy(&raw, data, n);
  can::Frame f;
  f.extended = (raw.can_id & CAN_EFF_FLAG) != 0;
  f.remote = (raw.can_id & CAN_RTR_FLAG) != 0;
  f.error = (raw.can_id & CAN_ERR_FLAG) != 0;
  f.id = raw.can_id & (f.extended ? CAN_EFF_MASK : CAN_SFF_MASK);
  f.fd = n == sizeof(canfd_frame);
  f.fd_flags = f.fd ? raw.flags : 0;
  const std::size_t maxlen = f.fd ? CANFD_MAX_DLEN : CAN_MAX_DLEN;
  f.len = static_cast<std::uint8_t>(std::min<std::size_t>(raw.len, maxlen));
  if (!f.remote) std::memcpy(f.data.data(), raw.data, f.len);
  return f;
}

std::vector<std::uint8_t> record_from_frame(const can::Frame& f) {
  can_frame raw{};
  raw.can_id = f.id | (f.extended ? CAN_EFF_FLAG : 0u) | (f.remote ? CAN_RTR_FLAG : 0u) |
               (f.error ? CAN_ERR_FLAG : 0u);
  raw.len = static_cast<std::uint8_t>(std::min<std::size_t>(f.len, CAN_MAX_DLEN));
  if (!f.remote) std::memcpy(raw.data, f.data.data(), raw.len);
  std::vector<std::uint8_t> out(sizeof raw);
  std::memcpy(out.data(), &raw, sizeof raw);
  return out;
}

CanSocket CanSocket::open(const std::string& iface, const std::vector<std::uint32_t>& ids) {
  const int fd = ::socket(PF_CAN, SOCK_RAW, CAN_RAW);
  if (fd < 0)
    throw SourceError(fmt::format("socketcan: cannot open a CAN socket for '{}': {}{}", iface,
                                  std::strerror(errno),
                                  errno == EAFNOSUPPORT ? " (no SocketCAN in this kernel)" : ""));
  CanSocket s(fd, iface);
  ifreq ifr{};
  if (iface.size() >= sizeof ifr.ifr_name)
    throw SourceError(fmt::format("socketcan: interface name '{}' is too long", iface));
  std::strncpy(ifr.ifr_name, iface.c_str(), sizeof ifr.ifr_name - 1);
  if (::ioctl(fd, SIOCGIFINDEX, &ifr) < 0)
    throw SourceError(
        fmt::format("socketcan: no CAN interface '{}': {}", iface, std::strerror(errno)));
  std::vector<can_filter> filters;
  filters.reserve(ids.size());
  for (std::uint32_t id : ids) filters.push_back({id, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG});
  if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, filters.data(),
                   static_cast<socklen_t>(filters.size() * sizeof(can_filter))) < 0)
    throw SourceError(
        fmt::format("socketcan: cannot set filters on '{}': {}", iface, std::strerror(errno)));
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = ifr.ifr_ifindex;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) < 0)
    throw SourceError(
        fmt::format("socketcan: cannot bind to '{}': {}", iface, std::strerror(errno)));
  return s;
}

CanSocket::CanSocket(int fd, std::string iface) : fd_(fd), iface_(std::move(iface)) {
  const int on = 1;
  ::setsockopt(fd_, SOL_SOCKET, SO_TIMESTAMP, &on, sizeof on);
  // The kernel's count of frames dropped on a full receive queue rides on every frame.
  ::setsockopt(fd_, SOL_SOCKET, SO_RXQ_OVFL, &on, sizeof on);
  // A larger receive queue (up to net.core.rmem_max) rides out bursts while the pipeline fits.
  const int rcvbuf = 4 << 20;
  ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
}

CanSocket::CanSocket(CanSocket&& o) noexcept : fd_(o.fd_), iface_(std::move(o.iface_)) {
  o.fd_ = -1;
}

CanSocket::~CanSocket() {
  if (fd_ >= 0) ::close(fd_);
}

std::optional<can::LoggedFrame> CanSocket::read(int timeout_ms, DriverCounters* counters) {
  pollfd p{fd_, POLLIN, 0};
  if (::poll(&p, 1, timeout_ms) <= 0 || !(p.revents & POLLIN)) return std::nullopt;
  alignas(canfd_frame) std::uint8_t buf[sizeof(canfd_frame)];
  alignas(cmsghdr) char ctrl[CMSG_SPACE(sizeof(timeval)) + CMSG_SPACE(sizeof(std::uint32_t))];
  iovec iov{buf, sizeof buf};
  msghdr msg{};
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  msg.msg_control = ctrl;
  msg.msg_controllen = sizeof ctrl;
  const ssize_t n = ::recvmsg(fd_, &msg, MSG_DONTWAIT);
  if (n <= 0) return std::nullopt;
  auto frame = frame_from_record(buf, static_cast<std::size_t>(n));
  if (!frame) {
    if (counters) ++counters->can_errors;
    return std::nullopt;
  }
  can::LoggedFrame lf;
  lf.iface = iface_;
  lf.frame = *frame;
  timespec now{};
  clock_gettime(CLOCK_REALTIME, &now);
  lf.t_us = static_cast<std::int64_t>(now.tv_sec) * 1'000'000 + now.tv_nsec / 1000;
  for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c; c = CMSG_NXTHDR(&msg, c)) {
    if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_TIMESTAMP) {
      timeval tv{};
      std::memcpy(&tv, CMSG_DATA(c), sizeof tv);
      lf.t_us = static_cast<std::int64_t>(tv.tv_sec) * 1'000'000 + tv.tv_usec;
    } else if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_RXQ_OVFL && counters) {
      std::uint32_t dropped = 0;  // the socket's total since it opened
      std::memcpy(&dropped, CMSG_DATA(c), sizeof dropped);
      counters->can_rx_dropped = dropped;
    }
  }
  if (counters) ++counters->frames;
  return lf;
}

SocketCanSource::SocketCanSource(CanSocket s, std::string iface)
    : sock_(std::move(s)), iface_(std::move(iface)) {
  th_ = std::thread([this] {
    while (!stop_) {
      auto f = sock_.read(100, &counters_);
      if (f && !q_.push(std::move(*f))) ++counters_.queue_drops;
    }
  });
}

SocketCanSource::~SocketCanSource() {
  stop_ = true;
  if (th_.joinable()) th_.join();
}

}  // namespace brakefit::drivers
