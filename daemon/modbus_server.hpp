#pragma once
// The Modbus TCP server. One thread owns the libmodbus context and the register mapping; the main
// loop hands it register writes through a queue. The thread frames requests itself from
// non-blocking sockets (poll loop, many clients), so a client that trickles bytes never stalls the
// others; it checks the MBAP header (protocol id 0, length = bytes that follow) before
// modbus_reply, and answers write function codes with an exception unless writes are enabled and
// the client is allow-listed.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "daemon/config.hpp"
#include "daemon/registers.hpp"

namespace brakefit::daemon {

struct ServerStats {
  std::atomic<std::uint64_t> requests{0};
  std::atomic<std::uint64_t> exceptions{0};  ///< exception replies
  std::atomic<std::uint64_t> malformed{0};   ///< bad MBAP header: connection closed
  std::atomic<std::uint64_t> rejected{0};    ///< connections refused or evicted (admission.hpp)
  std::atomic<std::uint64_t> timeouts{0};    ///< idle or trickling clients dropped
  std::atomic<int> clients{0};
};

struct HoldingCommand {
  std::uint16_t command = kCmdNone;
  std::optional<std::string> vehicle_id;
};

class ModbusServer {
 public:
  /// Binds and listens (port 0: an ephemeral port); throws std::runtime_error naming the address.
  explicit ModbusServer(const ModbusTcpConfig& c);
  ~ModbusServer();
  ModbusServer(const ModbusServer&) = delete;
  ModbusServer& operator=(const ModbusServer&) = delete;
  int port() const { return port_; }
  void start();
  void stop();
  /// Thread-safe. event_closed: when the event these writes publish was closed (latency).
  void post(RegisterWrites w,
            std::optional<std::chrono::steady_clock::time_point> event_closed = std::nullopt);
  /// Thread-safe: commands written by allow-listed clients since the last call.
  std::vector<HoldingCommand> take_commands();
  /// Thread-safe: the allow-list may change on reload.
  void set_write_policy(bool writable, std::vector<std::string> allow);
  /// Event-close to publish latencies (microseconds) measured so far.
  std::vector<double> publish_latencies_us();
  const ServerStats& stats() const { return stats_; }

 private:
  struct Client;
  void run();
  void apply_pending();
  bool handle(Client& c);  ///< false: close the connection
  void note_rejection(const std::string& what);
  ModbusTcpConfig cfg_;
  int listen_fd_ = -1, port_ = 0;
  int wake_[2] = {-1, -1};
  void* ctx_ = nullptr;      // modbus_t*, used only by the server thread
  void* mapping_ = nullptr;  // modbus_mapping_t*, ditto
  std::mutex mu_;
  std::vector<std::pair<RegisterWrites, std::optional<std::chrono::steady_clock::time_point>>>
      pending_;
  std::vector<HoldingCommand> commands_;
  std::vector<double> latencies_us_;
  bool writable_ = false;
  std::vector<std::string> allow_;
  ServerStats stats_;
  std::atomic<bool> stop_{false};
  std::chrono::steady_clock::time_point last_rejection_log_{};
  std::uint64_t rejections_unlogged_ = 0;
  std::thread th_;
};

}  // namespace brakefit::daemon
