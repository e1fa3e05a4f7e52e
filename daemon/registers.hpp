#pragma once
// The Modbus register map (documented in config/modbus_registers.csv and docs/modbus.md; a test
// checks the CSV against this table). Input registers (FC 04) carry status, counters, live values
// and the last finished event; holding registers (FC 03, writes FC 06/16 only when enabled and
// only for allow-listed clients) carry commands. 32-bit values are big-endian word order (ABCD),
// packed by our own code. Unset floats read as NaN.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace brakefit::daemon {

enum class RegTable : std::uint8_t { Input, Holding };
enum class RegType : std::uint8_t { U16, U32, F32, Ascii };

struct RegisterDef {
  const char* name;
  RegTable table;
  std::uint16_t address;
  std::uint16_t count;
  RegType type;
  const char* unit;
  const char* description;
};

inline constexpr std::uint16_t kMapVersion = 3;
inline constexpr std::uint16_t kInputRegisters = 200;
inline constexpr std::uint16_t kHoldingRegisters = 16;

/// Status flag bits (input register "status_flags").
enum StatusBit : std::uint16_t {
  kStatusRunning = 1u << 0,
  kStatusSourceFinished = 1u << 1,
  kStatusRefEncoderMissing = 1u << 2,
  kStatusWheelEncoderMissing = 1u << 3,
  kStatusPressureMissing = 1u << 4,
  kStatusEventActive = 1u << 5,
  kStatusStoreDegraded = 1u << 6,  ///< raw samples no longer stored (disk full)
  kStatusStoreError = 1u << 7,     ///< an event could not be stored at all
  kStatusRecorderError = 1u << 8,
  kStatusWritable = 1u << 9,
  kStatusEventsWaiting = 1u << 10,  ///< finished events wait for the store (not yet published)
};
/// Event flag bits (input register "event.flags").
enum EventFlagBit : std::uint16_t {
  kFlagTooShort = 1u << 0,
  kFlagAborted = 1u << 1,
  kFlagSensorFault = 1u << 2,
  kFlagNotFitted = 1u << 3,
  kFlagSamplesNotStored = 1u << 4,
  kFlagEdgesLost = 1u << 5,        ///< the GPIO reader lost edges during the event (still fitted)
  kFlagAtBound = 1u << 6,          ///< an lm or hybrid parameter ended on its bound (JSON at_bound)
  kFlagImplausibleData = 1u << 7,  ///< a reading outside physical ranges ended the event
  kFlagImplausibleResult = 1u << 8,  ///< an lm or hybrid curve no tyre gives (JSON implausible)
  /// The method blocks carry the tyre's fits (a bench measurement model's effects undone; JSON
  /// tyre_results, basis "tyre"), not the instrument's.
  kFlagTyreBasis = 1u << 9,
};
/// End reasons (input register "event.end_reason").
std::uint16_t end_reason_code(const std::string& reason);
/// Commands (holding register "command").
enum Command : std::uint16_t { kCmdNone = 0, kCmdArm = 1, kCmdAbort = 2 };

/// Methods in the order of their register blocks.
inline constexpr std::array<const char*, 4> kMethodBlocks{"som", "mlp", "lm", "hybrid"};

const std::vector<RegisterDef>& register_map();
/// Throws std::out_of_range naming the register.
const RegisterDef& reg(const std::string& name);
/// The CSV in config/ (header + one line per register).
std::string format_register_csv();

/// float32 as two registers, high word first (ABCD): 123456.0f -> {0x47F1, 0x2000}.
std::array<std::uint16_t, 2> pack_f32_abcd(float v);
float unpack_f32_abcd(std::uint16_t hi, std::uint16_t lo);
std::array<std::uint16_t, 2> pack_u32(std::uint32_t v);

/// A set of register writes (address, value), built on the main thread and applied by the server.
struct RegisterWrites {
  std::vector<std::pair<std::uint16_t, std::uint16_t>> input;
  void u16(const char* name, std::uint16_t v);
  void u32(const char* name, std::uint32_t v);
  void f32(const char* name, double v);
};

}  // namespace brakefit::daemon
