#pragma once
// The brake-line pressure transducer on Modbus RTU (libmodbus). A reader thread polls one value
// (a 16-bit register or a float32 pair in either word order) every poll period, scales it to bar
// and sends pressure frames (id 0x110); a failed read sends a frame with the fault status, and
// timeouts, errors and reconnects are counted.
#include <memory>
#include <string>
#include <thread>

#include "drivers/source.hpp"

namespace brakefit::drivers {

struct ModbusRtuConfig {
  std::string device = "/dev/ttyUSB0";
  int baud = 19200;
  char parity = 'E';  ///< 'N', 'E' or 'O'
  int data_bits = 8;
  int stop_bits = 1;
  int slave_id = 1;
  int register_address = 0;
  bool input_registers = true;  ///< FC 04; false: holding registers (FC 03)
  enum class Format { U16, S16, F32 } format = Format::U16;
  bool word_swap = false;  ///< float32 in CDAB (low word first) instead of ABCD
  double zero_counts = 0;  ///< raw value at 0 bar
  double span_bar_per_count = 0.01;
  int poll_period_ms = 10;
  int timeout_ms = 50;
  int reconnect_after_failures = 3;
  std::string iface = "rtu0";
};

/// Raw registers -> bar (pure, tested apart).
double rtu_pressure_bar(const ModbusRtuConfig& c, const std::uint16_t* regs);

class ModbusRtuPressureReader {
 public:
  /// Throws SourceError naming the device when the serial port is absent or cannot be opened.
  ModbusRtuPressureReader(const ModbusRtuConfig& c, FrameQueue& out, DriverCounters& counters,
                          const LiveClock& clock);
  ~ModbusRtuPressureReader();
  ModbusRtuPressureReader(const ModbusRtuPressureReader&) = delete;
  ModbusRtuPressureReader& operator=(const ModbusRtuPressureReader&) = delete;
  bool connected() const { return connected_; }

 private:
  void run();
  bool connect();
  ModbusRtuConfig cfg_;
  FrameQueue& out_;
  DriverCounters& counters_;
  const LiveClock& clock_;
  struct Ctx;
  std::unique_ptr<Ctx> ctx_;
  std::atomic<bool> stop_{false}, connected_{false};
  std::thread th_;
};

}  // namespace brakefit::drivers
