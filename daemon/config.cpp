#include "daemon/config.hpp"

#include <arpa/inet.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "core/toml_reader.hpp"

namespace brakefit::daemon {

namespace {

std::vector<std::string> string_list(const TomlReader& rd, const toml::table& t,
                                     const std::string& prefix, const char* key) {
  std::vector<std::string> out;
  const auto* node = t.get(key);
  if (!node) return out;
  const auto* arr = node->as_array();
  if (!arr) rd.fail(prefix + key, "expected an array of strings");
  for (const auto& v : *arr) {
    auto s = v.value_exact<std::string>();
    if (!s) rd.fail(prefix + key, "expected an array of strings");
    out.push_back(*s);
  }
  return out;
}

void parse_source(const TomlReader& rd, const toml::table& t, Config& c) {
  const std::string p = "source.";
  rd.check_keys(t, p, {"kind", "file", "speed", "exit_at_end", "loop", "interface"});
  const std::string kind = rd.string(t, p, "kind", "replay");
  if (kind == "replay")
    c.kind = SourceKind::Replay;
  else if (kind == "socketcan")
    c.kind = SourceKind::SocketCan;
  else if (kind == "gpio")
    c.kind = SourceKind::Gpio;
  else
    rd.fail(p + "kind",
            "expected 'replay', 'socketcan' or 'gpio' (gpio encoders + modbus-rtu pressure)");
  c.replay_file = rd.string(t, p, "file", "");
  if (c.kind == SourceKind::Replay && c.replay_file.empty())
    rd.fail(p + "file", "required when kind = 'replay'");
  c.replay_speed = rd.number(t, p, "speed", c.replay_speed, 0, 1000);
  c.exit_at_end = rd.boolean(t, p, "exit_at_end", c.exit_at_end);
  c.replay_loop = rd.boolean(t, p, "loop", c.replay_loop);
  c.can_interface = rd.string(t, p, "interface", c.can_interface);
  if (c.can_interface.empty() || c.can_interface.size() > 15)
    rd.fail(p + "interface", "expected a network interface name of 1 to 15 characters");
}

void parse_gpio(const TomlReader& rd, const toml::table& t, Config& c) {
  const std::string p = "gpio.";
  rd.check_keys(t, p,
                {"chip", "ref_a", "ref_b", "wheel_a", "wheel_b", "frame_period_ms", "uapi",
                 "event_buffer_size", "reader_rt_priority"});
  c.gpio.chip = rd.string(t, p, "chip", c.gpio.chip);
  const char* keys[4] = {"ref_a", "ref_b", "wheel_a", "wheel_b"};
  for (std::size_t i = 0; i < 4; ++i)
    c.gpio.offsets[i] =
        static_cast<unsigned>(rd.integer(t, p, keys[i], c.gpio.offsets[i], 0, 1023));
  c.gpio.frame_period_ms = static_cast<int>(rd.integer(t, p, "frame_period_ms", 1, 1, 100));
  const std::string uapi = rd.string(t, p, "uapi", "v2");
  if (uapi != "v1" && uapi != "v2")
    rd.fail(p + "uapi",
            "expected 'v2' (kernel GPIO uAPI v2: large FIFO, lost edges counted) or "
            "'v1' (libgpiod 1.6: 16 events per line, losses only seen as illegal "
            "transitions)");
  c.gpio.uapi = uapi == "v1" ? drivers::GpioConfig::Uapi::V1 : drivers::GpioConfig::Uapi::V2;
  c.gpio.event_buffer_size =
      static_cast<int>(rd.integer(t, p, "event_buffer_size", c.gpio.event_buffer_size, 16, 1024));
  c.gpio.reader_rt_priority =
      static_cast<int>(rd.integer(t, p, "reader_rt_priority", c.gpio.reader_rt_priority, 0, 99));
}

void parse_rtu(const TomlReader& rd, const toml::table& t, Config& c) {
  const std::string p = "modbus_rtu.";
  rd.check_keys(t, p,
                {"device", "baud", "parity", "data_bits", "stop_bits", "slave_id", "register",
                 "register_type", "format", "word_order", "zero_counts", "span_bar_per_count",
                 "poll_period_ms", "timeout_ms", "reconnect_after_failures"});
  auto& r = c.rtu;
  r.device = rd.string(t, p, "device", r.device);
  r.baud = static_cast<int>(rd.integer(t, p, "baud", r.baud, 300, 4'000'000));
  const std::string parity = rd.string(t, p, "parity", std::string(1, r.parity));
  if (parity != "N" && parity != "E" && parity != "O")
    rd.fail(p + "parity", "expected 'N', 'E' or 'O'");
  r.parity = parity[0];
  r.data_bits = static_cast<int>(rd.integer(t, p, "data_bits", r.data_bits, 5, 8));
  r.stop_bits = static_cast<int>(rd.integer(t, p, "stop_bits", r.stop_bits, 1, 2));
  r.slave_id = static_cast<int>(rd.integer(t, p, "slave_id", r.slave_id, 1, 247));
  r.register_address = static_cast<int>(rd.integer(t, p, "register", r.register_address, 0, 65534));
  const std::string rt = rd.string(t, p, "register_type", "input");
  if (rt != "input" && rt != "holding")
    rd.fail(p + "register_type", "expected 'input' or 'holding'");
  r.input_registers = rt == "input";
  const std::string fmt_s = rd.string(t, p, "format", "u16");
  if (fmt_s == "u16")
    r.format = drivers::ModbusRtuConfig::Format::U16;
  else if (fmt_s == "s16")
    r.format = drivers::ModbusRtuConfig::Format::S16;
  else if (fmt_s == "float32")
    r.format = drivers::ModbusRtuConfig::Format::F32;
  else
    rd.fail(p + "format", "expected 'u16', 's16' or 'float32'");
  const std::string wo = rd.string(t, p, "word_order", "ABCD");
  if (wo != "ABCD" && wo != "CDAB") rd.fail(p + "word_order", "expected 'ABCD' or 'CDAB'");
  r.word_swap = wo == "CDAB";
  r.zero_counts = rd.number(t, p, "zero_counts", r.zero_counts, -1e9, 1e9);
  r.span_bar_per_count = rd.number(t, p, "span_bar_per_count", r.span_bar_per_count, 1e-9, 1e6);
  r.poll_period_ms =
      static_cast<int>(rd.integer(t, p, "poll_period_ms", r.poll_period_ms, 1, 10000));
  r.timeout_ms = static_cast<int>(rd.integer(t, p, "timeout_ms", r.timeout_ms, 1, 10000));
  r.reconnect_after_failures = static_cast<int>(
      rd.integer(t, p, "reconnect_after_failures", r.reconnect_after_failures, 1, 1000));
}

void parse_pipeline(const TomlReader& rd, const toml::table& t, Config& c) {
  const std::string p = "pipeline.";
  rd.check_keys(
      t, p,
      {"methods", "force", "start_pressure_bar", "release_pressure_bar", "lock_slip_ratio",
       "min_ref_speed_mps", "min_points", "min_duration_s", "max_event_s", "max_speed_mps",
       "min_speed_mps", "max_pressure_bar", "min_pressure_bar"});
  auto& o = c.pipeline;
  if (t.get("methods")) {
    o.methods.clear();
    for (const auto& m : string_list(rd, t, p, "methods")) {
      Method mm{};
      if (!parse(m, mm))
        rd.fail(p + "methods", "unknown method '" + m + "' (som, mlp, lm, hybrid)");
      o.methods.push_back(mm);
    }
  }
  const std::string force = rd.string(t, p, "force", "pressure");
  if (force != "pressure" && force != "tester")
    rd.fail(p + "force", "expected 'pressure' or 'tester'");
  o.force = force == "tester" ? pipeline::ForceSource::Tester : pipeline::ForceSource::Pressure;
  auto& e = o.events;
  e.start_pressure_bar = rd.number(t, p, "start_pressure_bar", e.start_pressure_bar, 0.01, 500);
  e.release_pressure_bar = rd.number(t, p, "release_pressure_bar", e.release_pressure_bar, 0, 500);
  if (e.release_pressure_bar > e.start_pressure_bar)
    rd.fail(p + "release_pressure_bar", "must not exceed start_pressure_bar");
  e.lock_slip_ratio = rd.number(t, p, "lock_slip_ratio", e.lock_slip_ratio, 0.05, 1.0);
  e.min_ref_speed_mps = rd.number(t, p, "min_ref_speed_mps", e.min_ref_speed_mps, 0, 100);
  e.min_points = static_cast<std::size_t>(
      rd.integer(t, p, "min_points", static_cast<std::int64_t>(e.min_points), 5, 1'000'000));
  e.min_duration_s = rd.number(t, p, "min_duration_s", e.min_duration_s, 0, 600);
  e.max_event_s = rd.number(t, p, "max_event_s", e.max_event_s, 1, 3600);
  if (e.max_event_s <= e.min_duration_s) rd.fail(p + "max_event_s", "must exceed min_duration_s");
  e.max_speed_mps = rd.number(t, p, "max_speed_mps", e.max_speed_mps, 1, 1000);
  e.min_speed_mps = rd.number(t, p, "min_speed_mps", e.min_speed_mps, -1000, 0);
  e.max_pressure_bar = rd.number(t, p, "max_pressure_bar", e.max_pressure_bar, 1, 10000);
  e.min_pressure_bar = rd.number(t, p, "min_pressure_bar", e.min_pressure_bar, -10000, 0);
  if (e.start_pressure_bar > e.max_pressure_bar)
    rd.fail(p + "max_pressure_bar", "must be at least start_pressure_bar");
}

void parse_tcp(const TomlReader& rd, const toml::table& t, Config& c) {
  const std::string p = "modbus_tcp.";
  rd.check_keys(t, p,
                {"address", "port", "max_clients", "max_clients_per_address", "writable",
                 "write_allow", "idle_timeout_s", "protected"});
  auto& m = c.modbus_tcp;
  m.address = rd.string(t, p, "address", m.address);
  in_addr a{};
  if (inet_pton(AF_INET, m.address.c_str(), &a) != 1)
    rd.fail(p + "address", "expected an IPv4 address such as 0.0.0.0 or 127.0.0.1");
  m.port = static_cast<int>(rd.integer(t, p, "port", m.port, 0, 65535));
  m.max_clients = static_cast<int>(rd.integer(t, p, "max_clients", m.max_clients, 2, 1000));
  m.max_clients_per_address = static_cast<int>(
      rd.integer(t, p, "max_clients_per_address", m.max_clients_per_address, 1, 1000));
  m.writable = rd.boolean(t, p, "writable", m.writable);
  m.write_allow = string_list(rd, t, p, "write_allow");
  for (const auto& ip : m.write_allow)
    if (inet_pton(AF_INET, ip.c_str(), &a) != 1)
      rd.fail(p + "write_allow", "'" + ip + "' is not an IPv4 address");
  m.idle_timeout_s = rd.number(t, p, "idle_timeout_s", m.idle_timeout_s, 0.1, 86400);
  m.protect = string_list(rd, t, p, "protected");
  for (const auto& ip : m.protect)
    if (inet_pton(AF_INET, ip.c_str(), &a) != 1)
      rd.fail(p + "protected", "'" + ip + "' is not an IPv4 address");
}

void parse_store(const TomlReader& rd, const toml::table& t, Config& c) {
  const std::string p = "store.";
  rd.check_keys(t, p,
                {"path", "spill_dir", "retention_days", "max_events", "min_free_mb",
                 "store_samples", "hold_in_memory", "max_held", "retry_max_s"});
  auto& s = c.store;
  s.path = rd.string(t, p, "path", s.path);
  if (s.path.empty()) rd.fail(p + "path", "must not be empty");
  s.spill_dir = rd.string(t, p, "spill_dir", "");
  s.retention_days = rd.number(t, p, "retention_days", s.retention_days, 0.0001, 36500);
  s.max_events = static_cast<int>(rd.integer(t, p, "max_events", s.max_events, 1, 100'000'000));
  s.min_free_mb = rd.number(t, p, "min_free_mb", s.min_free_mb, 0, 1e7);
  s.store_samples = rd.boolean(t, p, "store_samples", s.store_samples);
  s.hold_in_memory =
      static_cast<int>(rd.integer(t, p, "hold_in_memory", s.hold_in_memory, 0, 10000));
  s.max_held = static_cast<int>(rd.integer(t, p, "max_held", s.max_held, 1, 100000));
  if (s.max_held < s.hold_in_memory) rd.fail(p + "max_held", "must be at least hold_in_memory");
  s.retry_max_s = rd.number(t, p, "retry_max_s", s.retry_max_s, 0.01, 3600);
}

void parse_record(const TomlReader& rd, const toml::table& t, Config& c) {
  const std::string p = "record.";
  rd.check_keys(t, p, {"enabled", "dir", "max_mb", "max_age_s", "keep_files"});
  auto& r = c.record;
  r.enabled = rd.boolean(t, p, "enabled", r.enabled);
  r.dir = rd.string(t, p, "dir", r.dir);
  r.max_mb = rd.number(t, p, "max_mb", r.max_mb, 0.001, 1e6);
  r.max_age_s = rd.number(t, p, "max_age_s", r.max_age_s, 1, 1e7);
  r.keep_files = static_cast<int>(rd.integer(t, p, "keep_files", r.keep_files, 1, 100000));
}

}  // namespace

Config parse_config(std::string_view text, const std::string& source) {
  const toml::table root = parse_toml(text, source);
  TomlReader rd(source);
  rd.check_keys(root, "",
                {"daemon", "source", "gpio", "modbus_rtu", "bench", "pipeline", "modbus_tcp",
                 "store", "record"});
  Config c;
  c.source_file = source;
  if (const auto* d = rd.table(root, "", "daemon")) {
    rd.check_keys(*d, "daemon.", {"log_level", "model", "sensor_timeout_s", "stats_file"});
    c.log_level = rd.string(*d, "daemon.", "log_level", c.log_level);
    if (c.log_level != "trace" && c.log_level != "debug" && c.log_level != "info" &&
        c.log_level != "warn" && c.log_level != "error")
      rd.fail("daemon.log_level", "expected trace, debug, info, warn or error");
    c.model_path = rd.string(*d, "daemon.", "model", c.model_path);
    c.sensor_timeout_s = rd.number(*d, "daemon.", "sensor_timeout_s", c.sensor_timeout_s, 0.01, 60);
    c.stats_file = rd.string(*d, "daemon.", "stats_file", c.stats_file);
  }
  const toml::table* src = rd.table(root, "", "source");
  if (!src) rd.fail("source", "missing [source] table");
  parse_source(rd, *src, c);
  const toml::table* g = rd.table(root, "", "gpio");
  const toml::table* r = rd.table(root, "", "modbus_rtu");
  if (c.kind == SourceKind::Gpio && !g) rd.fail("gpio", "required when source.kind = 'gpio'");
  if (c.kind == SourceKind::Gpio && !r)
    rd.fail("modbus_rtu", "required when source.kind = 'gpio' (the pressure transducer)");
  if (g) parse_gpio(rd, *g, c);
  if (r) parse_rtu(rd, *r, c);
  const toml::table* b = rd.table(root, "", "bench");
  if (!b) rd.fail("bench", "missing [bench] table (the bench calibration)");
  {
    // measurement_model is the daemon's key in [bench], not the calibration's (a recording's
    // .bench.toml has no such key).
    toml::table cal = *b;
    c.bench_model_path = rd.string(cal, "bench.", "measurement_model", "");
    cal.erase("measurement_model");
    c.calibration = pipeline::calibration_from_table(cal, rd, "bench.");
  }
  c.gpio.ground = c.calibration.bench == can::BenchKind::Ground;
  c.pipeline.events.sensor_timeout_s = c.sensor_timeout_s;
  c.pipeline.parallel_methods = true;
  c.pipeline.defer_fit = true;  // the daemon journals each event before its fit
  if (const auto* t = rd.table(root, "", "pipeline")) parse_pipeline(rd, *t, c);
  if (const auto* t = rd.table(root, "", "modbus_tcp")) parse_tcp(rd, *t, c);
  if (const auto* t = rd.table(root, "", "store")) parse_store(rd, *t, c);
  if (const auto* t = rd.table(root, "", "record")) parse_record(rd, *t, c);
  return c;
}

std::string read_text_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(fmt::format("{}: cannot read: {}", path, std::strerror(errno)));
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

Config load_config(const std::string& path) {
  Config c = parse_config(read_text_file(path), path);
  if (!c.bench_model_path.empty()) {
    try {
      c.pipeline.bench_model = std::make_shared<const gap::BenchModel>(
          gap::parse_bench_model(read_text_file(c.bench_model_path), c.bench_model_path));
    } catch (const std::exception& e) {
      throw std::runtime_error(
          fmt::format("{}: key 'bench.measurement_model': {}", path, e.what()));
    }
    const std::string bench = can::to_string(c.calibration.bench);
    if (c.pipeline.bench_model->condition != bench)
      throw std::runtime_error(fmt::format(
          "{}: key 'bench.measurement_model': {} is a {} bench's model and this bench is a {} "
          "bench",
          path, c.bench_model_path, c.pipeline.bench_model->condition, bench));
  }
  return c;
}

}  // namespace brakefit::daemon
