#include "daemon/modbus_server.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <modbus.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <spdlog/spdlog.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <limits>
#include <list>
#include <stdexcept>

#include "daemon/admission.hpp"
#include "daemon/modbus_gate.hpp"

namespace brakefit::daemon {

namespace {

using Clock = std::chrono::steady_clock;
constexpr std::size_t kMaxLatencies = 10000;

modbus_t* mb(void* p) {
  return static_cast<modbus_t*>(p);
}
modbus_mapping_t* map(void* p) {
  return static_cast<modbus_mapping_t*>(p);
}

}  // namespace

struct ModbusServer::Client {
  int fd = -1;
  std::string ip;
  std::vector<std::uint8_t> buf;
  Clock::time_point last_byte;
  std::optional<Clock::time_point> partial_since;
};

ModbusServer::ModbusServer(const ModbusTcpConfig& c) : cfg_(c) {
  writable_ = c.writable;
  allow_ = c.write_allow;
  listen_fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (listen_fd_ < 0)
    throw std::runtime_error(fmt::format("modbus_tcp: socket: {}", std::strerror(errno)));
  const int on = 1;
  ::setsockopt(listen_fd_, SOL_SOCKET, SO_REUSEADDR, &on, sizeof on);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(c.port));
  inet_pton(AF_INET, c.address.c_str(), &a.sin_addr);
  if (::bind(listen_fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) < 0 ||
      ::listen(listen_fd_, 256) < 0) {
    const std::string err = std::strerror(errno);
    ::close(listen_fd_);
    throw std::runtime_error(
        fmt::format("modbus_tcp: cannot listen on {}:{}: {}{}", c.address, c.port, err,
                    c.port < 1024 ? " (ports below 1024 need CAP_NET_BIND_SERVICE)" : ""));
  }
  socklen_t len = sizeof a;
  ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&a), &len);
  port_ = ntohs(a.sin_port);
  if (::pipe2(wake_, O_NONBLOCK | O_CLOEXEC) < 0)
    throw std::runtime_error(fmt::format("modbus_tcp: pipe: {}", std::strerror(errno)));
  ctx_ = modbus_new_tcp("127.0.0.1", port_);
  mapping_ = modbus_mapping_new(0, 0, kHoldingRegisters, kInputRegisters);
  if (!ctx_ || !mapping_) throw std::runtime_error("modbus_tcp: cannot allocate the context");
  auto* m = map(mapping_);
  // Every float reads NaN until set; counters read 0.
  for (const auto& r : register_map()) {
    if (r.table != RegTable::Input || r.type != RegType::F32) continue;
    const auto w = pack_f32_abcd(std::numeric_limits<float>::quiet_NaN());
    m->tab_input_registers[r.address] = w[0];
    m->tab_input_registers[r.address + 1] = w[1];
  }
  m->tab_input_registers[reg("map_version").address] = kMapVersion;
}

ModbusServer::~ModbusServer() {
  stop();
  if (mapping_) modbus_mapping_free(map(mapping_));
  if (ctx_) modbus_free(mb(ctx_));
  if (listen_fd_ >= 0) ::close(listen_fd_);
  for (int fd : wake_)
    if (fd >= 0) ::close(fd);
}

void ModbusServer::start() {
  th_ = std::thread([this] { run(); });
}

void ModbusServer::stop() {
  stop_ = true;
  if (wake_[1] >= 0) [[maybe_unused]]
    auto n = ::write(wake_[1], "x", 1);
  if (th_.joinable()) th_.join();
}

void ModbusServer::post(RegisterWrites w, std::optional<Clock::time_point> event_closed) {
  {
    std::lock_guard lk(mu_);
    pending_.emplace_back(std::move(w), event_closed);
  }
  [[maybe_unused]] auto n = ::write(wake_[1], "x", 1);
}

std::vector<HoldingCommand> ModbusServer::take_commands() {
  std::lock_guard lk(mu_);
  return std::exchange(commands_, {});
}

void ModbusServer::set_write_policy(bool writable, std::vector<std::string> allow) {
  std::lock_guard lk(mu_);
  writable_ = writable;
  allow_ = std::move(allow);
}

std::vector<double> ModbusServer::publish_latencies_us() {
  std::lock_guard lk(mu_);
  return latencies_us_;
}

void ModbusServer::apply_pending() {
  std::vector<std::pair<RegisterWrites, std::optional<Clock::time_point>>> todo;
  {
    std::lock_guard lk(mu_);
    todo.swap(pending_);
  }
  auto* m = map(mapping_);
  for (auto& [w, closed] : todo) {
    for (auto [addr, v] : w.input)
      if (addr < kInputRegisters) m->tab_input_registers[addr] = v;
    if (closed) {
      const double us = std::chrono::duration<double, std::micro>(Clock::now() - *closed).count();
      std::lock_guard lk(mu_);
      latencies_us_.push_back(us);
      // A station runs for years: keep the newest latencies only (bounded memory).
      if (latencies_us_.size() > 2 * kMaxLatencies)
        latencies_us_.erase(latencies_us_.begin(),
                            latencies_us_.end() - static_cast<std::ptrdiff_t>(kMaxLatencies));
    }
  }
  m->tab_input_registers[reg("modbus_clients").address] =
      static_cast<std::uint16_t>(stats_.clients.load());
  const auto rq = pack_u32(static_cast<std::uint32_t>(stats_.requests.load()));
  m->tab_input_registers[reg("modbus_requests").address] = rq[0];
  m->tab_input_registers[reg("modbus_requests").address + 1] = rq[1];
  const auto ex = pack_u32(static_cast<std::uint32_t>(stats_.exceptions + stats_.malformed));
  m->tab_input_registers[reg("modbus_exceptions").address] = ex[0];
  m->tab_input_registers[reg("modbus_exceptions").address + 1] = ex[1];
  const auto rj = pack_u32(static_cast<std::uint32_t>(stats_.rejected.load()));
  m->tab_input_registers[reg("modbus_rejected").address] = rj[0];
  m->tab_input_registers[reg("modbus_rejected").address + 1] = rj[1];
}

bool ModbusServer::handle(Client& c) {
  std::uint8_t tmp[512];
  for (;;) {
    const ssize_t n = ::recv(c.fd, tmp, sizeof tmp, MSG_DONTWAIT);
    if (n == 0) return false;
    if (n < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK) break;
      if (errno == EINTR) continue;
      return false;
    }
    c.buf.insert(c.buf.end(), tmp, tmp + n);
    if (c.buf.size() > 4 * kMaxAdu) break;
  }
  const auto now = Clock::now();
  c.last_byte = now;
  auto* m = map(mapping_);
  while (c.buf.size() >= 8) {
    bool allowed = false;
    {
      std::lock_guard lk(mu_);
      allowed = writable_ && std::find(allow_.begin(), allow_.end(), c.ip) != allow_.end();
    }
    const GateDecision g = gate_request(c.buf.data(), c.buf.size(), allowed);
    if (g.result == GateResult::NeedMore) break;
    if (g.result == GateResult::Drop) {
      ++stats_.malformed;  // not Modbus TCP (or a lying MBAP length): drop the connection
      return false;
    }
    const std::size_t total = g.total;
    std::array<std::uint8_t, kMaxAdu> adu{};  // zero padded: libmodbus never reads past it
    std::copy_n(c.buf.begin(), total, adu.begin());
    c.buf.erase(c.buf.begin(), c.buf.begin() + static_cast<std::ptrdiff_t>(total));
    modbus_set_socket(mb(ctx_), c.fd);
    const std::uint8_t fc = adu[7];
    int rc = 0;
    ++stats_.requests;
    if (g.result == GateResult::Exception) {
      ++stats_.exceptions;
      rc = modbus_reply_exception(mb(ctx_), adu.data(), g.exception);
    } else {
      std::array<std::uint16_t, kHoldingRegisters> before{};
      std::copy_n(m->tab_registers, kHoldingRegisters, before.begin());
      rc = modbus_reply(mb(ctx_), adu.data(), static_cast<int>(total), m);
      if (is_write_function(fc)) {
        HoldingCommand cmd;
        const auto ca = reg("command").address;
        if (m->tab_registers[ca] != kCmdNone) {
          cmd.command = m->tab_registers[ca];
          m->tab_registers[ca] = kCmdNone;
          ++m->tab_registers[reg("command_count").address];
        }
        const auto& vr = reg("vehicle_id");
        if (!std::equal(before.begin() + vr.address, before.begin() + vr.address + vr.count,
                        m->tab_registers + vr.address)) {
          std::string id;
          for (std::uint16_t i = 0; i < vr.count; ++i)
            for (int shift : {8, 0}) {
              const char ch = static_cast<char>((m->tab_registers[vr.address + i] >> shift) & 0xFF);
              if (ch >= 0x20 && ch < 0x7F) id += ch;
            }
          cmd.vehicle_id = id;
        }
        if (cmd.command != kCmdNone || cmd.vehicle_id) {
          std::lock_guard lk(mu_);
          commands_.push_back(cmd);
        }
      }
    }
    if (rc < 0) return false;  // the client does not read its replies: drop it
  }
  if (c.buf.empty())
    c.partial_since.reset();
  else if (!c.partial_since)
    c.partial_since = now;
  return true;
}

void ModbusServer::note_rejection(const std::string& what) {
  ++stats_.rejected;
  // A flood of connections must not flood the journal: at most one line a second, with a count.
  const auto now = Clock::now();
  ++rejections_unlogged_;
  if (now - last_rejection_log_ < std::chrono::seconds(1)) return;
  spdlog::warn(
      "modbus_tcp: {}{}", what,
      rejections_unlogged_ > 1
          ? fmt::format(" ({} refusals/evictions since the last message)", rejections_unlogged_)
          : "");
  rejections_unlogged_ = 0;
  last_rejection_log_ = now;
}

void ModbusServer::run() {
  std::list<Client> clients;
  const auto idle = std::chrono::duration<double>(cfg_.idle_timeout_s);
  const auto partial = std::chrono::duration<double>(std::min(1.0, cfg_.idle_timeout_s));
  std::vector<pollfd> fds;
  while (!stop_) {
    apply_pending();
    fds.clear();
    fds.push_back({wake_[0], POLLIN, 0});
    fds.push_back({listen_fd_, POLLIN, 0});
    for (const auto& c : clients) fds.push_back({c.fd, POLLIN, 0});
    const int n = ::poll(fds.data(), fds.size(), 100);
    if (n < 0 && errno != EINTR) break;
    if (fds[0].revents & POLLIN) {
      char drain[64];
      while (::read(wake_[0], drain, sizeof drain) > 0) {
      }
    }
    apply_pending();  // writes first, so a request after a post sees them
    const auto now = Clock::now();
    std::size_t i = 2;
    for (auto it = clients.begin(); it != clients.end(); ++i) {
      bool keep = true;
      if (fds[i].revents & (POLLIN | POLLHUP | POLLERR)) keep = handle(*it);
      if (keep && (now - it->last_byte > idle ||
                   (it->partial_since && now - *it->partial_since > partial))) {
        ++stats_.timeouts;
        keep = false;
      }
      if (!keep) {
        ::close(it->fd);
        it = clients.erase(it);
        --stats_.clients;
      } else {
        ++it;
      }
    }
    if (fds[1].revents & POLLIN) {
      for (;;) {
        sockaddr_in peer{};
        socklen_t len = sizeof peer;
        const int fd = ::accept4(listen_fd_, reinterpret_cast<sockaddr*>(&peer), &len,
                                 SOCK_NONBLOCK | SOCK_CLOEXEC);
        if (fd < 0) break;
        char ip[INET_ADDRSTRLEN] = {};
        inet_ntop(AF_INET, &peer.sin_addr, ip, sizeof ip);
        std::vector<ConnectionView> open;
        open.reserve(clients.size());
        for (const auto& c : clients) open.push_back({c.ip, c.last_byte});
        const Admission a = admit_connection(open, ip, cfg_.max_clients,
                                             cfg_.max_clients_per_address, cfg_.protect);
        if (a.evict) {
          auto victim = std::next(clients.begin(), static_cast<std::ptrdiff_t>(*a.evict));
          note_rejection(fmt::format("evicted {} for {} ({})", victim->ip, ip, a.reason));
          ::close(victim->fd);
          clients.erase(victim);
          --stats_.clients;
        }
        if (!a.admit) {
          note_rejection(fmt::format("refused {} ({})", ip, a.reason));
          ::close(fd);
          continue;
        }
        const int on = 1;
        ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);
        clients.push_back({fd, ip, {}, Clock::now(), std::nullopt});
        ++stats_.clients;
      }
    }
  }
  for (auto& c : clients) ::close(c.fd);
  stats_.clients = 0;
}

}  // namespace brakefit::daemon
