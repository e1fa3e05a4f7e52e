// The Modbus RTU pressure driver without hardware: register scaling in both word orders, and
// polling a fake slave on a pty pair (timeouts and reconnects counted).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <pty.h>
#include <termios.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <mutex>
#include <thread>

#include "core/can/layout.hpp"
#include "drivers/modbus_rtu.hpp"
#include "test_util.hpp"
#include "tests/tools/rtu_crc.hpp"

using namespace brakefit;
using namespace brakefit::drivers;

namespace {

/// A Modbus RTU slave on the master side of a pty: answers FC 03/04 from a register table, or
/// stays silent while `mute` is set.
class FakeSlave {
 public:
  FakeSlave() {
    termios tio{};
    cfmakeraw(&tio);
    EXPECT_EQ(::openpty(&master_, &slave_, name_, &tio, nullptr), 0);
    th_ = std::thread([this] { run(); });
  }
  ~FakeSlave() {
    stop_ = true;
    th_.join();
    ::close(master_);
    ::close(slave_);
  }
  std::string device() const { return name_; }
  std::atomic<bool> mute{false};
  std::atomic<int> requests{0};
  std::array<std::atomic<std::uint16_t>, 8> regs{};

 private:
  void run() {
    std::vector<std::uint8_t> buf;
    while (!stop_) {
      pollfd p{master_, POLLIN, 0};
      if (::poll(&p, 1, 20) <= 0) continue;
      std::uint8_t tmp[256];
      const ssize_t n = ::read(master_, tmp, sizeof tmp);
      if (n <= 0) continue;
      buf.insert(buf.end(), tmp, tmp + n);
      while (buf.size() >= 8) {
        std::vector<std::uint8_t> req(buf.begin(), buf.begin() + 8);
        buf.erase(buf.begin(), buf.begin() + 8);
        ++requests;
        if (mute) continue;
        const std::uint16_t crc = brakefit::test::rtu_crc16(req.data(), 6);
        if (req[6] != (crc & 0xFF) || req[7] != (crc >> 8)) continue;
        const unsigned addr = (req[2] << 8) | req[3], qty = (req[4] << 8) | req[5];
        std::vector<std::uint8_t> resp{req[0], req[1], static_cast<std::uint8_t>(2 * qty)};
        for (unsigned i = 0; i < qty; ++i) {
          const std::uint16_t v = addr + i < regs.size() ? regs[addr + i].load() : 0;
          resp.push_back(static_cast<std::uint8_t>(v >> 8));
          resp.push_back(static_cast<std::uint8_t>(v & 0xFF));
        }
        const std::uint16_t c = brakefit::test::rtu_crc16(resp.data(), resp.size());
        resp.push_back(static_cast<std::uint8_t>(c & 0xFF));
        resp.push_back(static_cast<std::uint8_t>(c >> 8));
        [[maybe_unused]] auto w = ::write(master_, resp.data(), resp.size());
      }
    }
  }
  int master_ = -1, slave_ = -1;
  char name_[128] = {};
  std::atomic<bool> stop_{false};
  std::thread th_;
};

}  // namespace

TEST(ModbusRtu, ScalesRegistersInBothWordOrders) {
  ModbusRtuConfig c;
  c.format = ModbusRtuConfig::Format::F32;
  c.zero_counts = 0;
  c.span_bar_per_count = 1;
  const std::uint16_t abcd[2] = {0x47F1, 0x2000};  // 123456.0f
  EXPECT_DOUBLE_EQ(rtu_pressure_bar(c, abcd), 123456.0);
  c.word_swap = true;
  const std::uint16_t cdab[2] = {0x2000, 0x47F1};
  EXPECT_DOUBLE_EQ(rtu_pressure_bar(c, cdab), 123456.0);
  c.format = ModbusRtuConfig::Format::U16;
  c.zero_counts = 400;
  c.span_bar_per_count = 0.05;
  const std::uint16_t raw[1] = {1400};
  EXPECT_DOUBLE_EQ(rtu_pressure_bar(c, raw), 50.0);
  c.format = ModbusRtuConfig::Format::S16;
  c.zero_counts = 0;
  const std::uint16_t neg[1] = {0xFFF6};  // -10
  EXPECT_DOUBLE_EQ(rtu_pressure_bar(c, neg), -0.5);
}

TEST(ModbusRtu, PollsAFakeSlaveOverAPtyAndCountsTimeoutsAndReconnects) {
  FakeSlave slave;
  slave.regs[2] = 0x4148;  // 12.5f = 0x41480000
  slave.regs[3] = 0x0000;
  ModbusRtuConfig c;
  c.device = slave.device();
  c.baud = 115200;
  c.register_address = 2;
  c.format = ModbusRtuConfig::Format::F32;
  c.span_bar_per_count = 1;
  c.poll_period_ms = 5;
  c.timeout_ms = 30;
  c.reconnect_after_failures = 2;
  FrameQueue q;
  DriverCounters counters;
  LiveClock clock;
  ModbusRtuPressureReader reader(c, q, counters, clock);
  int ok = 0;
  for (int i = 0; i < 200 && ok < 5; ++i) {
    auto f = q.pop(100);
    if (!f) continue;
    const auto m = std::get<can::PressureMsg>(*can::decode(f->frame));
    if (m.status == 0) {
      EXPECT_NEAR(m.pressure_bar, 12.5, 0.01);
      ++ok;
    }
  }
  EXPECT_EQ(ok, 5);
  slave.mute = true;  // the transducer stops answering
  int faults = 0;
  for (int i = 0; i < 100 && faults < 6; ++i) {
    auto f = q.pop(200);
    if (f && std::get<can::PressureMsg>(*can::decode(f->frame)).status == 1) ++faults;
  }
  EXPECT_GE(faults, 6);
  EXPECT_GE(counters.rtu_timeouts.load(), 4u);
  EXPECT_GE(counters.rtu_reconnects.load(), 1u);
  slave.mute = false;  // and recovers
  bool recovered = false;
  for (int i = 0; i < 100 && !recovered; ++i) {
    auto f = q.pop(200);
    recovered = f && std::get<can::PressureMsg>(*can::decode(f->frame)).status == 0;
  }
  EXPECT_TRUE(recovered);
}

TEST(ModbusRtu, AbsentSerialPortIsNamed) {
  ModbusRtuConfig c;
  c.device = "/dev/ttyBRAKEFIT404";
  FrameQueue q;
  DriverCounters counters;
  LiveClock clock;
  try {
    ModbusRtuPressureReader r(c, q, counters, clock);
    FAIL();
  } catch (const SourceError& e) {
    EXPECT_NE(std::string(e.what()).find("/dev/ttyBRAKEFIT404"), std::string::npos);
  }
}
