#pragma once
// The durable event store (SQLite, WAL, synchronous=FULL): every finished event's raw samples and
// results in one transaction, committed before the event is published, then checkpointed (PASSIVE,
// after every commit; TRUNCATE on close) so the main file holds what is committed. Opening for
// writing copies a write-ahead log that does not end cleanly aside (logged) and proves the store
// writable with a real write. On a full disk (free
// space below min_free_mb, or SQLITE_FULL) raw samples stop being stored, results are still
// kept, and degraded() is raised; nothing half-written is ever visible.
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/pipeline/pipeline.hpp"
#include "daemon/config.hpp"
#include "daemon/record.hpp"

struct sqlite3;

namespace brakefit::daemon {

struct StoredEvent {
  std::int64_t id = 0;  ///< row id: the event id published over Modbus
  std::int64_t created_unix_s = 0;
  std::string source, vehicle_id, bench, end_reason, flags, model_hash;
  int pipeline_event_id = 0;
  std::int64_t t_start_ns = 0, t_end_ns = 0;
  std::int64_t points = 0;
  bool samples_stored = false;
  std::string calibration_toml;
  std::string result_json;  ///< brakefit.event/1 document
  std::string uid;          ///< random, made once per event (empty: a row from before uids)
};

class EventStore {
 public:
  /// Opens (creating when writable) the database; throws std::runtime_error naming the path and
  /// the system's reason (no such directory, not a directory, permission denied).
  /// busy_timeout_ms: how long one commit waits for another process's lock; the daemon keeps it
  /// short and retries from its loop.
  EventStore(const StoreConfig& c, bool read_only, int busy_timeout_ms = 2000);
  ~EventStore();
  EventStore(const EventStore&) = delete;
  EventStore& operator=(const EventStore&) = delete;

  /// Commits the event; returns its row id, or std::nullopt when even the results could not be
  /// stored (error() then says why). samples_stored: whether the raw samples went in too.
  std::optional<std::int64_t> commit(const EventRecord& r, bool* samples_stored = nullptr);
  std::optional<std::int64_t> commit(const pipeline::EventResult& e, const std::string& result_json,
                                     const std::string& calibration_toml,
                                     const std::string& vehicle_id, const std::string& source,
                                     const std::string& model_hash, std::int64_t now_unix_s,
                                     bool* samples_stored = nullptr);
  /// The id of the stored event with this record's uid (a spilled record whose commit went
  /// through before a crash), if any.
  std::optional<std::int64_t> find(const EventRecord& r) const;
  /// The newest stored event (restored into the registers after a restart).
  std::optional<StoredEvent> last() const;
  /// Deletes events older than retention_days or beyond max_events; returns how many.
  int apply_retention(std::int64_t now_unix_s);
  std::vector<StoredEvent> list(int limit) const;
  std::optional<StoredEvent> get(std::int64_t id) const;
  /// Events with a row id above after_id, committed at or after min_created_unix_s, oldest
  /// first (what `brakefit sync` ships next).
  std::vector<StoredEvent> after(std::int64_t after_id, std::int64_t min_created_unix_s,
                                 int limit) const;
  std::int64_t count_after(std::int64_t after_id, std::int64_t min_created_unix_s) const;
  /// An event's raw samples as stored (the packed blob; empty when none), and their count.
  std::string samples_blob(std::int64_t id, std::int64_t* count = nullptr) const;
  std::vector<pipeline::Sample> samples(std::int64_t id) const;
  std::int64_t count() const;
  /// "ok" or SQLite's integrity_check report.
  std::string integrity_check() const;
  bool degraded() const { return degraded_; }
  const std::string& error() const { return error_; }
  /// Test hook: limits the database to this many pages (simulates a full disk).
  void set_max_pages(int pages);

 private:
  bool disk_low() const;
  void probe_write();
  void checkpoint(bool truncate);
  int insert(const EventRecord& r, bool with_samples, std::int64_t& id);
  StoreConfig cfg_;
  sqlite3* db_ = nullptr;
  bool degraded_ = false;
  bool writable_ = false;
  std::string error_;
};

}  // namespace brakefit::daemon
