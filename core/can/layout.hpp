#pragma once
// The brakefit CAN frame layout (documented in config/brakefit.dbc; a test checks the two agree).
// Encoder frames carry a cumulative x4 count (modulo 2^24) and the sender's time of the last edge
// (microseconds, modulo 2^32), so the same frames can record a live GPIO session.
#include <cstdint>
#include <optional>
#include <variant>
#include <vector>

#include "core/can/dbc.hpp"

namespace brakefit::can {

inline constexpr std::uint32_t kIdRollerEncoder = 0x100;
inline constexpr std::uint32_t kIdWheelEncoder = 0x101;
inline constexpr std::uint32_t kIdFifthWheelEncoder = 0x102;
inline constexpr std::uint32_t kIdEncoderFaults = 0x103;
inline constexpr std::uint32_t kIdBrakePressure = 0x110;
inline constexpr std::uint32_t kIdTesterForce = 0x120;
inline constexpr std::uint32_t kIdTestState = 0x130;

/// The compiled message table (ids, signals, scaling, units).
const std::vector<MessageDef>& layout();
const MessageDef& message(std::uint32_t id);

enum class Channel : std::uint8_t { Roller, Wheel, FifthWheel };
enum class BenchKind : std::uint8_t { Roller = 0, Ground = 1 };
enum class TestState : std::uint8_t {
  Idle = 0,
  Running = 1,
  Measuring = 2,
  SwitchedOff = 3,
  Aborted = 4
};
const char* to_string(BenchKind b);

struct EncoderMsg {
  Channel channel = Channel::Wheel;
  std::uint32_t count_x4_mod = 0;  ///< cumulative x4 count modulo 2^24
  std::uint32_t edge_time_us = 0;  ///< sender clock, modulo 2^32
  std::uint8_t counter = 0;
};
struct PressureMsg {
  double pressure_bar = 0.0;
  std::uint8_t status = 0;  ///< 0 ok, 1 sensor fault
  std::uint8_t counter = 0;
  std::uint32_t sample_time_us = 0;
};
struct TesterForceMsg {
  double brake_force_n = 0.0;
  std::uint8_t counter = 0;
  std::uint32_t sample_time_us = 0;
};
struct TestStateMsg {
  TestState state = TestState::Idle;
  BenchKind bench = BenchKind::Roller;
  std::uint8_t counter = 0;
  double set_speed_kmh = 0.0;
  std::uint8_t wheel = 1;  ///< 0 FL, 1 FR, 2 RL, 3 RR
};
/// What a GPIO reader knows it lost: edges the kernel dropped (v2 uAPI sequence-number gaps) and
/// illegal quadrature transitions, both cumulative modulo 2^24. Sent when either changes (and once
/// at start); an event during which they grow is flagged edges_lost.
struct EncoderFaultsMsg {
  std::uint32_t lost_edges_mod = 0;
  std::uint32_t illegal_transitions_mod = 0;
  std::uint8_t counter = 0;
};
using BenchMsg =
    std::variant<EncoderMsg, PressureMsg, TesterForceMsg, TestStateMsg, EncoderFaultsMsg>;

/// std::nullopt for an id that is not in the layout (or a remote/error frame).
std::optional<BenchMsg> decode(const Frame& f);
Frame encode(const BenchMsg& m);

}  // namespace brakefit::can
