#include "daemon/registers.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstring>
#include <deque>
#include <map>
#include <stdexcept>

namespace brakefit::daemon {

namespace {

std::vector<RegisterDef> build_map() {
  using T = RegTable;
  using Y = RegType;
  std::vector<RegisterDef> m = {
      {"map_version", T::Input, 0, 1, Y::U16, "", "register map version (3)"},
      {"status_flags", T::Input, 1, 1, Y::U16, "bits",
       "0 running, 1 source finished, 2 ref encoder missing, 3 wheel encoder missing, 4 pressure "
       "missing, 5 event active, 6 store degraded (samples not stored), 7 store error (the last "
       "commit failed; retrying), 8 recorder error, 9 writable, 10 events waiting for the store "
       "(finished, not yet stored nor published)"},
      {"uptime_s", T::Input, 2, 2, Y::U32, "s", "seconds since start"},
      {"frames", T::Input, 4, 2, Y::U32, "", "frames received from the source"},
      {"events_finished", T::Input, 6, 2, Y::U32, "", "brake events finished since start"},
      {"events_flagged", T::Input, 8, 2, Y::U32, "",
       "finished events flagged (aborted, short, fault)"},
      {"illegal_transitions", T::Input, 10, 2, Y::U32, "",
       "illegal quadrature transitions (a sign of dropped GPIO edges)"},
      {"rtu_timeouts", T::Input, 12, 2, Y::U32, "", "Modbus RTU pressure read timeouts"},
      {"rtu_reconnects", T::Input, 14, 2, Y::U32, "", "Modbus RTU reconnects"},
      {"counter_gaps", T::Input, 16, 2, Y::U32, "", "lost frames detected by rolling counters"},
      {"unknown_ids", T::Input, 18, 2, Y::U32, "", "frames with ids not in the layout"},
      {"queue_drops", T::Input, 20, 2, Y::U32, "", "frames dropped by a full driver queue"},
      {"modbus_requests", T::Input, 22, 2, Y::U32, "", "Modbus TCP requests answered"},
      {"modbus_exceptions", T::Input, 24, 2, Y::U32, "",
       "Modbus TCP exception replies and refused frames"},
      {"modbus_clients", T::Input, 26, 1, Y::U16, "", "connected Modbus TCP clients"},
      {"events_waiting", T::Input, 27, 1, Y::U16, "",
       "finished events not yet stored (so not yet published): in memory or spilled"},
      {"events_spilled", T::Input, 28, 1, Y::U16, "",
       "of those, spilled to files beside the store"},
      {"store_failures", T::Input, 29, 2, Y::U32, "", "failed commit attempts (each retried)"},
      {"events_lost", T::Input, 31, 2, Y::U32, "",
       "finished events dropped: the store and the spill directory both failed past max_held"},
      {"modbus_rejected", T::Input, 33, 2, Y::U32, "",
       "Modbus TCP connections refused or evicted (per-address limit, max_clients)"},
      {"encoder_resyncs", T::Input, 35, 2, Y::U32, "",
       "encoder edge clocks that went back while counts moved (a bench that restarted)"},
      {"v_ref_mps", T::Input, 40, 2, Y::F32, "m/s",
       "reference speed (roller surface or fifth wheel)"},
      {"v_wheel_mps", T::Input, 42, 2, Y::F32, "m/s", "tested wheel circumferential speed"},
      {"slip_ratio", T::Input, 44, 2, Y::F32, "1", "slip = 1 - v_wheel / v_ref (Eq. 1)"},
      {"pressure_bar", T::Input, 46, 2, Y::F32, "bar", "brake-line pressure"},
      {"force_n", T::Input, 48, 2, Y::F32, "N", "tester force reading (NaN when absent)"},
      {"lost_edges", T::Input, 50, 2, Y::U32, "",
       "GPIO edges the kernel dropped (v2 uAPI sequence-number gaps; the v1 uAPI cannot tell)"},
      {"can_rx_dropped", T::Input, 52, 2, Y::U32, "",
       "CAN frames the kernel dropped because the socket's receive queue was full (SO_RXQ_OVFL)"},
      {"event.seq_begin", T::Input, 100, 1, Y::U16, "",
       "event sequence, written first (equal to event.seq when the block is consistent)"},
      {"event.id", T::Input, 101, 2, Y::U32, "", "event id (row id in the event store)"},
      {"event.bench", T::Input, 103, 1, Y::U16, "", "0 roller, 1 ground"},
      {"event.flags", T::Input, 104, 1, Y::U16, "bits",
       "0 too short, 1 aborted, 2 sensor fault, 3 not fitted, 4 samples not stored, 5 edges lost "
       "(GPIO edges dropped or illegal transitions during the event; still fitted), 6 a "
       "least-squares "
       "parameter (lm or hybrid) at its bound: set by the bound, not the data (JSON at_bound), 7 "
       "implausible data: a speed or pressure outside physical ranges ended the event (not "
       "fitted), 8 implausible result: an lm or hybrid curve no tyre gives (peak friction or "
       "shape; JSON implausible), 9 tyre basis: the method blocks carry the tyre's fits with the "
       "bench measurement model's effects undone (JSON tyre_results); clear: the instrument's "
       "(JSON results)"},
      {"event.end_reason", T::Input, 105, 1, Y::U16, "",
       "1 switch_off_slip, 2 wheel_lock, 3 release, 4 stopped, 5 sensor_timeout, 6 end_of_data, 7 "
       "tester_aborted, 8 operator_abort, 9 shutdown, 10 max_length, 11 implausible_data, 0 "
       "other"},
      {"event.duration_ms", T::Input, 106, 2, Y::U32, "ms", "event duration"},
      {"event.points", T::Input, 108, 1, Y::U16, "", "slip/force points fitted"},
      {"event.peak_force_n", T::Input, 109, 2, Y::F32, "N", "largest measured brake force"},
      {"event.peak_slip_ratio", T::Input, 111, 2, Y::F32, "1", "largest measured slip"},
      {"event.model_hash", T::Input, 113, 2, Y::U32, "", "first 32 bits of the model's SHA-256"},
      {"event.t_end_unix_s", T::Input, 115, 2, Y::U32, "s", "event end, Unix time (source clock)"},
  };
  for (std::uint16_t k = 0; k < kMethodBlocks.size(); ++k) {
    static std::deque<std::string> names;  // stable storage for the generated names
    static std::deque<std::string> descs;
    const std::uint16_t base = static_cast<std::uint16_t>(120 + 12 * k);
    const char* fields[6] = {"B", "C", "D", "E", "mape_pct", "rmse_n"};
    const char* units[6] = {"1", "1", "N", "1", "%", "N"};
    for (std::uint16_t i = 0; i < 6; ++i) {
      names.push_back(fmt::format("event.{}.{}", kMethodBlocks[k], fields[i]));
      descs.push_back(i < 4 ? fmt::format("Magic Formula {} by {}", fields[i], kMethodBlocks[k])
                            : fmt::format("{} of the {} fit", fields[i], kMethodBlocks[k]));
      m.push_back({names.back().c_str(), T::Input, static_cast<std::uint16_t>(base + 2 * i), 2,
                   Y::F32, units[i], descs.back().c_str()});
    }
  }
  m.push_back({"event.seq", T::Input, 168, 1, Y::U16, "",
               "event sequence, written last: re-read the block when it differs from seq_begin"});
  m.push_back({"command", T::Holding, 0, 1, Y::U16, "",
               "write 1 to arm a test (no pedal release needed), 2 to abort the running event"});
  m.push_back({"command_count", T::Holding, 1, 1, Y::U16, "", "commands accepted (read back)"});
  m.push_back({"vehicle_id", T::Holding, 2, 8, Y::Ascii, "",
               "vehicle id, 16 ASCII characters, stored with the following events"});
  return m;
}

const char* type_name(RegType t) {
  switch (t) {
    case RegType::U16:
      return "u16";
    case RegType::U32:
      return "u32";
    case RegType::F32:
      return "f32_abcd";
    case RegType::Ascii:
      return "ascii";
  }
  return "?";
}

}  // namespace

const std::vector<RegisterDef>& register_map() {
  static const std::vector<RegisterDef> m = build_map();
  return m;
}

const RegisterDef& reg(const std::string& name) {
  static const std::map<std::string, const RegisterDef*> by_name = [] {
    std::map<std::string, const RegisterDef*> out;
    for (const auto& r : register_map()) out[r.name] = &r;
    return out;
  }();
  auto it = by_name.find(name);
  if (it == by_name.end()) throw std::out_of_range("no register named '" + name + "'");
  return *it->second;
}

std::string format_register_csv() {
  std::string out = "name,table,address,count,type,unit,description\n";
  for (const auto& r : register_map())
    out += fmt::format("{},{},{},{},{},{},\"{}\"\n", r.name,
                       r.table == RegTable::Input ? "input" : "holding", r.address, r.count,
                       type_name(r.type), r.unit, r.description);
  return out;
}

std::uint16_t end_reason_code(const std::string& reason) {
  static const std::map<std::string, std::uint16_t> codes = {
      {"switch_off_slip", 1}, {"wheel_lock", 2},  {"release", 3},          {"stopped", 4},
      {"sensor_timeout", 5},  {"end_of_data", 6}, {"tester_aborted", 7},   {"operator_abort", 8},
      {"shutdown", 9},        {"max_length", 10}, {"implausible_data", 11}};
  auto it = codes.find(reason);
  return it == codes.end() ? 0 : it->second;
}

std::array<std::uint16_t, 2> pack_f32_abcd(float v) {
  std::uint32_t bits = 0;
  std::memcpy(&bits, &v, sizeof bits);
  return {static_cast<std::uint16_t>(bits >> 16), static_cast<std::uint16_t>(bits & 0xFFFFu)};
}

float unpack_f32_abcd(std::uint16_t hi, std::uint16_t lo) {
  const std::uint32_t bits = (static_cast<std::uint32_t>(hi) << 16) | lo;
  float v = 0;
  std::memcpy(&v, &bits, sizeof v);
  return v;
}

std::array<std::uint16_t, 2> pack_u32(std::uint32_t v) {
  return {static_cast<std::uint16_t>(v >> 16), static_cast<std::uint16_t>(v & 0xFFFFu)};
}

void RegisterWrites::u16(const char* name, std::uint16_t v) {
  input.emplace_back(reg(name).address, v);
}

void RegisterWrites::u32(const char* name, std::uint32_t v) {
  const auto a = reg(name).address;
  const auto w = pack_u32(v);
  input.emplace_back(a, w[0]);
  input.emplace_back(static_cast<std::uint16_t>(a + 1), w[1]);
}

void RegisterWrites::f32(const char* name, double v) {
  const auto a = reg(name).address;
  const auto w = pack_f32_abcd(static_cast<float>(v));
  input.emplace_back(a, w[0]);
  input.emplace_back(static_cast<std::uint16_t>(a + 1), w[1]);
}

}  // namespace brakefit::daemon
