#pragma once
// The station side of the fleet path (`brakefit sync`): reads the station's store without blocking
// brakefitd's commits (SQLite WAL: a reader takes no write lock, and each read is one short
// transaction), ships committed events in batches to the central server, and keeps going through
// every fault: the server down, killed mid-batch, slow, moved, or refusing the credentials. A
// failed batch is retried after a backoff (1 s doubling to max_backoff_s); nothing is skipped, and
// a retried batch cannot duplicate (fleet/shipper.hpp). Its status (backlog, last success, last
// failure) goes to the log, to systemd (STATUS=) and to a JSON file `brakefit events list` reads.
#include <cstdint>
#include <functional>
#include <map>
#include <string>

#include "fleet/shipper.hpp"

namespace brakefit::fleet {

struct SyncOptions {
  std::string store_path;
  std::string url;                              ///< without a password
  std::map<std::string, std::string> settings;  ///< libpq settings (password, sslmode, ...)
  StationIds ids;
  std::string status_path;  ///< empty: <store>.sync.json
  int batch = 500;
  bool with_samples = false;
  bool once = false;  ///< ship the backlog and exit (75 if the server could not take it)
  double poll_s = 1.0;
  double max_backoff_s = 300.0;
  int statement_timeout_ms = 60000;
  std::function<bool()> stop;  ///< polled between steps (SIGTERM)
};

struct SyncStatus {
  std::string state = "starting";  ///< shipping, idle, retrying, credentials_refused
  std::int64_t backlog = -1;       ///< committed events not yet shipped (-1: unknown)
  std::int64_t shipped = 0;        ///< new central rows this run
  std::int64_t already_there = 0;  ///< sent but already central (a retry, a resume margin)
  std::int64_t last_success_unix_s = 0;
  std::int64_t last_failure_unix_s = 0;
  std::string last_failure;
  int consecutive_failures = 0;
  double next_retry_s = 0;
};

std::string status_json(const SyncStatus& s, const SyncOptions& o);
/// The line `brakefit events list` prints for a status file, e.g. "sync: backlog 0, last success
/// 2026-11-26T12:00:00Z"; empty when there is no readable file.
std::string status_line(const std::string& status_path);
std::string default_status_path(const std::string& store_path);

/// Runs until stop() (exit 0), or with once until the backlog is shipped (0) or a batch failed
/// (75, EX_TEMPFAIL).
int run_sync(const SyncOptions& o);

}  // namespace brakefit::fleet
