#include "core/can/layout.hpp"

#include <stdexcept>

namespace brakefit::can {

namespace {

MessageDef encoder_message(std::uint32_t id, const char* name) {
  return {id,
          name,
          8,
          {{"count_x4", 0, 24, false, 1, 0, 0, 16777215, "count"},
           {"edge_time_us", 24, 32, false, 1, 0, 0, 4294967295.0, "us"},
           {"counter", 56, 8, false, 1, 0, 0, 255, ""}}};
}

}  // namespace

const char* to_string(BenchKind b) {
  return b == BenchKind::Roller ? "roller" : "ground";
}

const std::vector<MessageDef>& layout() {
  static const std::vector<MessageDef> kLayout = {
      encoder_message(kIdRollerEncoder, "ROLLER_ENCODER"),
      encoder_message(kIdWheelEncoder, "WHEEL_ENCODER"),
      encoder_message(kIdFifthWheelEncoder, "FIFTH_WHEEL_ENCODER"),
      {kIdBrakePressure,
       "BRAKE_PRESSURE",
       8,
       {{"pressure_bar", 0, 16, false, 0.01, 0, 0, 655.35, "bar"},
        {"status", 16, 8, false, 1, 0, 0, 255, ""},
        {"counter", 24, 8, false, 1, 0, 0, 255, ""},
        {"sample_time_us", 32, 32, false, 1, 0, 0, 4294967295.0, "us"}}},
      {kIdTesterForce,
       "TESTER_FORCE",
       8,
       {{"brake_force_n", 0, 24, true, 0.1, 0, -838860.8, 838860.7, "N"},
        {"counter", 24, 8, false, 1, 0, 0, 255, ""},
        {"sample_time_us", 32, 32, false, 1, 0, 0, 4294967295.0, "us"}}},
      {kIdTestState,
       "TEST_STATE",
       8,
       {{"state", 0, 8, false, 1, 0, 0, 4, ""},
        {"bench", 8, 8, false, 1, 0, 0, 1, ""},
        {"counter", 16, 8, false, 1, 0, 0, 255, ""},
        {"set_speed_kmh", 24, 16, false, 0.01, 0, 0, 655.35, "km/h"},
        {"wheel", 40, 8, false, 1, 0, 0, 3, ""}}},
      {kIdEncoderFaults,
       "ENCODER_FAULTS",
       8,
       {{"lost_edges", 0, 24, false, 1, 0, 0, 16777215, "count"},
        {"illegal_transitions", 24, 24, false, 1, 0, 0, 16777215, "count"},
        {"counter", 48, 8, false, 1, 0, 0, 255, ""}}},
  };
  return kLayout;
}

const MessageDef& message(std::uint32_t id) {
  for (const auto& m : layout())
    if (m.id == id) return m;
  throw std::out_of_range("no such message id");
}

std::optional<BenchMsg> decode(const Frame& f) {
  if (f.extended || f.remote || f.error || f.fd) return std::nullopt;
  auto u = [&](const MessageDef& m, const char* s) {
    return static_cast<std::uint32_t>(extract_raw(f, m.signal(s)));
  };
  switch (f.id) {
    case kIdRollerEncoder:
    case kIdWheelEncoder:
    case kIdFifthWheelEncoder: {
      const MessageDef& m = message(f.id);
      EncoderMsg e;
      e.channel = f.id == kIdRollerEncoder  ? Channel::Roller
                  : f.id == kIdWheelEncoder ? Channel::Wheel
                                            : Channel::FifthWheel;
      e.count_x4_mod = u(m, "count_x4");
      e.edge_time_us = u(m, "edge_time_us");
      e.counter = static_cast<std::uint8_t>(u(m, "counter"));
      return e;
    }
    case kIdBrakePressure: {
      const MessageDef& m = message(f.id);
      PressureMsg p;
      p.pressure_bar = decode_signal(f, m.signal("pressure_bar"));
      p.status = static_cast<std::uint8_t>(u(m, "status"));
      p.counter = static_cast<std::uint8_t>(u(m, "counter"));
      p.sample_time_us = u(m, "sample_time_us");
      return p;
    }
    case kIdTesterForce: {
      const MessageDef& m = message(f.id);
      TesterForceMsg t;
      t.brake_force_n = decode_signal(f, m.signal("brake_force_n"));
      t.counter = static_cast<std::uint8_t>(u(m, "counter"));
      t.sample_time_us = u(m, "sample_time_us");
      return t;
    }
    case kIdTestState: {
      const MessageDef& m = message(f.id);
      TestStateMsg s;
      s.state = static_cast<TestState>(u(m, "state"));
      s.bench = static_cast<BenchKind>(u(m, "bench"));
      s.counter = static_cast<std::uint8_t>(u(m, "counter"));
      s.set_speed_kmh = decode_signal(f, m.signal("set_speed_kmh"));
      s.wheel = static_cast<std::uint8_t>(u(m, "wheel"));
      return s;
    }
    case kIdEncoderFaults: {
      const MessageDef& m = message(f.id);
      EncoderFaultsMsg e;
      e.lost_edges_mod = u(m, "lost_edges");
      e.illegal_transitions_mod = u(m, "illegal_transitions");
      e.counter = static_cast<std::uint8_t>(u(m, "counter"));
      return e;
    }
    default:
      return std::nullopt;
  }
}

Frame encode(const BenchMsg& msg) {
  Frame f;
  f.len = 8;
  std::visit(
      [&](const auto& m) {
        using T = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<T, EncoderMsg>) {
          f.id = m.channel == Channel::Roller  ? kIdRollerEncoder
                 : m.channel == Channel::Wheel ? kIdWheelEncoder
                                               : kIdFifthWheelEncoder;
          const MessageDef& d = message(f.id);
          encode_signal(f, d.signal("count_x4"), m.count_x4_mod & 0xFFFFFFu);
          encode_signal(f, d.signal("edge_time_us"), m.edge_time_us);
          encode_signal(f, d.signal("counter"), m.counter);
        } else if constexpr (std::is_same_v<T, PressureMsg>) {
          f.id = kIdBrakePressure;
          const MessageDef& d = message(f.id);
          encode_signal(f, d.signal("pressure_bar"), m.pressure_bar);
          encode_signal(f, d.signal("status"), m.status);
          encode_signal(f, d.signal("counter"), m.counter);
          encode_signal(f, d.signal("sample_time_us"), m.sample_time_us);
        } else if constexpr (std::is_same_v<T, TesterForceMsg>) {
          f.id = kIdTesterForce;
          const MessageDef& d = message(f.id);
          encode_signal(f, d.signal("brake_force_n"), m.brake_force_n);
          encode_signal(f, d.signal("counter"), m.counter);
          encode_signal(f, d.signal("sample_time_us"), m.sample_time_us);
        } else if constexpr (std::is_same_v<T, EncoderFaultsMsg>) {
          f.id = kIdEncoderFaults;
          const MessageDef& d = message(f.id);
          encode_signal(f, d.signal("lost_edges"), m.lost_edges_mod & 0xFFFFFFu);
          encode_signal(f, d.signal("illegal_transitions"), m.illegal_transitions_mod & 0xFFFFFFu);
          encode_signal(f, d.signal("counter"), m.counter);
        } else {
          f.id = kIdTestState;
          const MessageDef& d = message(f.id);
          encode_signal(f, d.signal("state"), static_cast<double>(m.state));
          encode_signal(f, d.signal("bench"), static_cast<double>(m.bench));
          encode_signal(f, d.signal("counter"), m.counter);
          encode_signal(f, d.signal("set_speed_kmh"), m.set_speed_kmh);
          encode_signal(f, d.signal("wheel"), m.wheel);
        }
      },
      msg);
  return f;
}

}  // namespace brakefit::can
