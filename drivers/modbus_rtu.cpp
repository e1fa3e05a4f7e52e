#include "drivers/modbus_rtu.hpp"

#include <fmt/format.h>
#include <modbus.h>
#include <sys/stat.h>

#include <cerrno>
#include <chrono>
#include <cstring>

#include "core/can/layout.hpp"

namespace brakefit::drivers {

double rtu_pressure_bar(const ModbusRtuConfig& c, const std::uint16_t* regs) {
  double raw = 0;
  switch (c.format) {
    case ModbusRtuConfig::Format::U16:
      raw = regs[0];
      break;
    case ModbusRtuConfig::Format::S16:
      raw = static_cast<std::int16_t>(regs[0]);
      break;
    case ModbusRtuConfig::Format::F32: {
      const std::uint32_t hi = c.word_swap ? regs[1] : regs[0];
      const std::uint32_t lo = c.word_swap ? regs[0] : regs[1];
      const std::uint32_t bits = (hi << 16) | lo;
      float f = 0;
      std::memcpy(&f, &bits, sizeof f);
      raw = f;
      break;
    }
  }
  return (raw - c.zero_counts) * c.span_bar_per_count;
}

struct ModbusRtuPressureReader::Ctx {
  modbus_t* m = nullptr;
  ~Ctx() {
    if (m) {
      modbus_close(m);
      modbus_free(m);
    }
  }
};

ModbusRtuPressureReader::ModbusRtuPressureReader(const ModbusRtuConfig& c, FrameQueue& out,
                                                 DriverCounters& counters, const LiveClock& clock)
    : cfg_(c), out_(out), counters_(counters), clock_(clock), ctx_(std::make_unique<Ctx>()) {
  struct stat st {};
  if (::stat(c.device.c_str(), &st) != 0 || !S_ISCHR(st.st_mode))
    throw SourceError(fmt::format("modbus-rtu: no serial port '{}'", c.device));
  ctx_->m = modbus_new_rtu(c.device.c_str(), c.baud, c.parity, c.data_bits, c.stop_bits);
  if (!ctx_->m)
    throw SourceError(fmt::format("modbus-rtu: bad serial settings for '{}': {}", c.device,
                                  modbus_strerror(errno)));
  modbus_set_slave(ctx_->m, c.slave_id);
  const auto us = static_cast<std::uint32_t>(c.timeout_ms) * 1000u;
  modbus_set_response_timeout(ctx_->m, us / 1'000'000u, us % 1'000'000u);
  if (!connect())
    throw SourceError(fmt::format("modbus-rtu: cannot open serial port '{}': {}", c.device,
                                  modbus_strerror(errno)));
  th_ = std::thread([this] { run(); });
}

ModbusRtuPressureReader::~ModbusRtuPressureReader() {
  stop_ = true;
  if (th_.joinable()) th_.join();
}

bool ModbusRtuPressureReader::connect() {
  connected_ = modbus_connect(ctx_->m) == 0;
  return connected_;
}

void ModbusRtuPressureReader::run() {
  const int nregs = cfg_.format == ModbusRtuConfig::Format::F32 ? 2 : 1;
  int failures = 0;
  std::uint8_t counter = 0;
  auto next = std::chrono::steady_clock::now();
  while (!stop_) {
    next += std::chrono::milliseconds(cfg_.poll_period_ms);
    can::PressureMsg m;
    m.counter = counter++;
    if (!connected_ && !connect()) {
      ++counters_.rtu_errors;
      m.status = 1;
    } else {
      std::uint16_t regs[2] = {0, 0};
      const int rc = cfg_.input_registers
                         ? modbus_read_input_registers(ctx_->m, cfg_.register_address, nregs, regs)
                         : modbus_read_registers(ctx_->m, cfg_.register_address, nregs, regs);
      ++counters_.rtu_reads;
      if (rc == nregs) {
        failures = 0;
        m.pressure_bar = rtu_pressure_bar(cfg_, regs);
      } else {
        m.status = 1;
        if (errno == ETIMEDOUT)
          ++counters_.rtu_timeouts;
        else
          ++counters_.rtu_errors;
        modbus_flush(ctx_->m);
        if (++failures >= cfg_.reconnect_after_failures) {
          modbus_close(ctx_->m);
          connected_ = false;
          ++counters_.rtu_reconnects;
          failures = 0;
        }
      }
    }
    const std::int64_t t = clock_.now_mono_ns();
    m.sample_time_us = static_cast<std::uint32_t>(t / 1000);
    can::LoggedFrame f;
    f.t_us = clock_.wall_us(t);
    f.iface = cfg_.iface;
    f.frame = can::encode(m);
    if (!out_.push(std::move(f))) ++counters_.queue_drops;
    ++counters_.frames;
    std::this_thread::sleep_until(next);
    if (next < std::chrono::steady_clock::now()) next = std::chrono::steady_clock::now();
  }
}

}  // namespace brakefit::drivers
