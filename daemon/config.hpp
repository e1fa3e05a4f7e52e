#pragma once
// brakefitd's configuration (/etc/brakefit/brakefitd.toml): validated strictly on start and on
// SIGHUP; an unknown key, a wrong type or a value out of range names the key (exit 78).
#include <string>
#include <vector>

#include "core/identify.hpp"
#include "core/pipeline/calibration.hpp"
#include "core/pipeline/pipeline.hpp"
#include "drivers/gpio.hpp"
#include "drivers/modbus_rtu.hpp"

namespace brakefit::daemon {

enum class SourceKind { Replay, SocketCan, Gpio };

struct ModbusTcpConfig {
  std::string address = "0.0.0.0";
  int port = 1502;
  int max_clients = 128;
  /// One address may hold at most this many connections; a new address always gets a slot (the
  /// idlest connection of the address holding most is evicted for it).
  int max_clients_per_address = 16;
  bool writable = false;                   ///< command holding registers accept writes
  std::vector<std::string> write_allow{};  ///< client IPv4 addresses allowed to write
  double idle_timeout_s = 60;              ///< an idle (or trickling) client is dropped after this
  /// Client IPv4 addresses never evicted to make room (the station software's own connection).
  std::vector<std::string> protect{};
};

struct StoreConfig {
  std::string path = "/var/lib/brakefit/events.db";
  double retention_days = 365;
  int max_events = 100000;
  double min_free_mb = 64;  ///< below this, raw samples stop being stored (results are kept)
  bool store_samples = true;
  /// The journal and spill directory; empty: PATH.spill. Another filesystem keeps events when
  /// the store's is full.
  std::string spill_dir;
  /// While commits fail, finished events wait unpublished: this many keep a copy in memory, the
  /// rest are read back from their journal files (every event is journaled as it closes).
  int hold_in_memory = 0;
  int max_held = 256;        ///< in memory when spilling fails too; older ones are dropped, counted
  double retry_max_s = 5.0;  ///< commit retries back off from 0.1 s to this
};

struct RecordConfig {
  bool enabled = true;
  std::string dir = "/var/lib/brakefit/recordings";
  double max_mb = 64;
  double max_age_s = 3600;
  int keep_files = 48;
};

struct Config {
  std::string source_file;  ///< the config file itself (errors name it)
  std::string log_level = "info";
  std::string model_path;  ///< empty: no model (LM only)
  /// [bench] measurement_model: the bench's measurement model (brakefit gap --bench-model); each
  /// event is also fitted on the tyre's basis, and those results are published (empty: none).
  std::string bench_model_path;
  double sensor_timeout_s = 0.5;
  std::string stats_file;  ///< written on exit: counters and publish latencies (bench)
  SourceKind kind = SourceKind::Replay;
  std::string replay_file;
  double replay_speed = 1.0;  ///< 0: as fast as possible
  bool exit_at_end = false;
  bool replay_loop = false;  ///< replay again and again, stamps shifted (soak benches)
  std::string can_interface = "can0";
  drivers::GpioConfig gpio;
  drivers::ModbusRtuConfig rtu;
  pipeline::Calibration calibration;
  pipeline::PipelineOptions pipeline;
  ModbusTcpConfig modbus_tcp;
  StoreConfig store;
  RecordConfig record;
};

/// Throws InputError "FILE: key 'a.b': ..." on any invalid content.
Config parse_config(std::string_view text, const std::string& source);
/// Reads and parses the file (start and SIGHUP); an unreadable file is an InputError naming it.
Config load_config(const std::string& path);
/// A whole file as text; InputError "PATH: cannot read: ..." when it cannot be read.
std::string read_text_file(const std::string& path);

}  // namespace brakefit::daemon
