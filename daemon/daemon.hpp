#pragma once
// brakefitd's main loop: source -> recorder -> pipeline -> store -> Modbus registers, with
// sd_notify READY/RELOADING/STATUS/WATCHDOG, SIGHUP reload and a clean SIGTERM exit.
#include <atomic>
#include <chrono>
#include <memory>
#include <optional>
#include <string>

#include "core/exit_codes.hpp"
#include "daemon/config.hpp"
#include "daemon/instance_lock.hpp"
#include "daemon/modbus_server.hpp"
#include "daemon/pending.hpp"
#include "daemon/store.hpp"
#include "drivers/replay.hpp"

namespace brakefit::daemon {

/// Exit codes: 69 a configured source is absent, 71 cannot listen, 73 cannot open the store,
/// 78 configuration invalid (core/exit_codes.hpp); DaemonError carries one.
using DaemonError = ExitError;

/// One commit waits this long for another process's lock, then the loop goes on and retries.
inline constexpr int kStoreBusyTimeoutMs = 100;

/// Set from signal handlers.
struct Signals {
  std::atomic<bool> stop{false};
  std::atomic<bool> reload{false};
};

class Daemon {
 public:
  /// Opens everything the config names; throws DaemonError with the exit code and a message
  /// naming what is missing.
  Daemon(std::string config_path, Config cfg, Signals& sig);
  ~Daemon();
  int run();
  /// The model at `path` (empty: none, LM only); DaemonError 78 naming 'daemon.model' if it cannot
  /// be read or is damaged. Also `brakefitd --check`.
  static std::unique_ptr<const Model> load_model(const std::string& path);

 private:
  using Clock = std::chrono::steady_clock;
  void reload();
  /// Journals each event the pipeline closed, fits it, and commits and publishes it.
  void publish_finished(Clock::time_point closed);
  EventRecord fitted_record(const pipeline::EventResult& er, const std::string& calibration,
                            const std::string& vehicle_id, const std::string& source,
                            std::int64_t created_unix_s, bool count);
  bool fit_journaled(const EventRecord& r);
  /// A channel silent in the data's own time (its newest stamp sensor_timeout_s behind the
  /// newest of any channel), or, right after a poll found nothing, every channel silent that
  /// long; 3 for every channel.
  std::optional<int> silent_channel(Clock::time_point now, bool polled_empty) const;
  /// The clean stop: what could not be stored stays in the spill directory; what could not be
  /// written there either is lost, counted and said. Returns the exit code.
  int stop_pending();
  /// Commits waiting events oldest first and publishes each after its commit; on a failure
  /// stops and retries later (fresh: an event just finished, try now whatever the backoff).
  void commit_pending(Clock::time_point closed, bool fresh);
  void restore_last_event();
  void post_status(Clock::time_point now);
  void notify_status();
  std::uint16_t status_flags(Clock::time_point now) const;
  bool channel_missing(int ch, Clock::time_point now) const;

  std::string config_path_;
  Config cfg_;
  Signals& sig_;
  std::unique_ptr<InstanceLock> lock_;  ///< first taken, last released
  std::unique_ptr<const Model> model_;  ///< stable address: the pipeline points into it
  std::unique_ptr<EventStore> store_;
  std::unique_ptr<PendingEvents> pending_;
  std::unique_ptr<ModbusServer> server_;
  std::unique_ptr<drivers::FrameSource> source_;
  std::unique_ptr<drivers::CandumpRecorder> recorder_;
  std::unique_ptr<pipeline::Pipeline> pipeline_;
  std::string vehicle_id_;
  std::uint64_t events_finished_ = 0, events_flagged_ = 0, store_failures_ = 0;
  double retry_delay_s_ = 0.1;
  Clock::time_point next_retry_{};
  bool recorder_error_ = false, store_error_ = false, source_finished_ = false;
  bool reload_pending_ = false;
  Clock::time_point start_;
  std::array<std::optional<Clock::time_point>, 3> seen_{};  ///< ref, wheel, pressure
  std::array<std::optional<std::int64_t>, 3> stamp_us_{};   ///< their newest frames' stamps
  std::int64_t newest_stamp_us_ = 0;
  std::optional<Clock::time_point> idle_since_;  ///< polls found nothing since then
  std::string last_status_;
};

}  // namespace brakefit::daemon
