#pragma once
// Helpers shared by the daemon unit tests: a made-up finished event, a temporary directory, raw
// loopback sockets.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "core/curve.hpp"
#include "core/event_json.hpp"
#include "core/pipeline/pipeline.hpp"
#include "daemon/config.hpp"
#include "daemon/record.hpp"

namespace brakefit::test {

inline pipeline::EventResult make_event(int id, std::size_t n) {
  pipeline::EventResult e;
  e.event.event_id = id;
  e.event.t_start_ns = 1'000'000'000LL * id;
  e.event.t_end_ns = e.event.t_start_ns + 2'000'000'000LL;
  e.event.end_reason = "switch_off_slip";
  for (std::size_t i = 0; i < n; ++i) {
    pipeline::Sample s;
    s.t_ns = e.event.t_start_ns + static_cast<std::int64_t>(i) * 1'000'000;
    s.v_ref_mps = 1.389;
    s.v_wheel_mps = 1.389 * (1 - 0.27 * static_cast<double>(i) / static_cast<double>(n));
    s.pressure_bar = 0.05 * static_cast<double>(i);
    s.force_n = i % 2 ? NAN : 3.0 * static_cast<double>(i);
    s.state = can::TestState::Measuring;
    s.sensor_fault = i == 3;
    e.event.samples.push_back(s);
    e.curve.slip_ratio.push_back(pipeline::slip_ratio(s));
    e.curve.force_n.push_back(66.7 * s.pressure_bar);
  }
  return e;
}

/// A made-up finished event as the store keeps it.
inline daemon::EventRecord make_test_record(int id, std::size_t n = 50) {
  const auto e = make_event(id, n);
  return daemon::make_record(e, event_json(e, "test", nullptr).dump(), "[bench]\n", "V1", "test",
                             "sha256:abcdef0123", 1000 + id);
}

/// The error parse_config gives for this text ("" when it parses).
inline std::string config_error(const std::string& text) {
  try {
    daemon::parse_config(text, "test.toml");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

/// The smallest config that parses; tests append a table to it.
inline const char* kMinimalConfig =
    "[source]\nkind = \"replay\"\nfile = \"x.log\"\n[bench]\nkind = \"roller\"\n";

struct TempDir {
  std::filesystem::path p;
  TempDir() {
    p = std::filesystem::temp_directory_path() /
        ("bf_daemon_" + std::to_string(::getpid()) + "_" +
         std::to_string(std::chrono::steady_clock::now().time_since_epoch().count()));
    std::filesystem::create_directories(p);
  }
  ~TempDir() { std::filesystem::remove_all(p); }
};

/// A TCP connection to 127.0.0.1:port from source address `from` (any 127.x address is local).
inline int raw_connect(int port, const char* from = "127.0.0.1") {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in src{};
  src.sin_family = AF_INET;
  ::inet_pton(AF_INET, from, &src.sin_addr);
  EXPECT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&src), sizeof src), 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  EXPECT_EQ(::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  return fd;
}

/// Bytes received within timeout_ms; empty on close/timeout.
inline std::vector<std::uint8_t> raw_recv(int fd, int timeout_ms) {
  pollfd p{fd, POLLIN, 0};
  if (::poll(&p, 1, timeout_ms) <= 0) return {};
  std::vector<std::uint8_t> b(300);
  const ssize_t n = ::recv(fd, b.data(), b.size(), 0);
  b.resize(n > 0 ? static_cast<std::size_t>(n) : 0);
  return b;
}

}  // namespace brakefit::test
