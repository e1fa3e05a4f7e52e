#include "daemon/store.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <sqlite3.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <stdexcept>

#include "core/curve.hpp"
#include "daemon/store_sql.hpp"
#include "daemon/wal_check.hpp"

namespace brakefit::daemon {

using sql::exec;
using sql::Stmt;

namespace {

constexpr const char* kSchema = R"sql(
CREATE TABLE IF NOT EXISTS events (
  id INTEGER PRIMARY KEY AUTOINCREMENT,
  created_unix_s INTEGER NOT NULL,
  source TEXT NOT NULL,
  vehicle_id TEXT NOT NULL,
  pipeline_event_id INTEGER NOT NULL,
  bench TEXT NOT NULL,
  t_start_ns INTEGER NOT NULL,
  t_end_ns INTEGER NOT NULL,
  end_reason TEXT NOT NULL,
  flags TEXT NOT NULL,
  points INTEGER NOT NULL,
  model_hash TEXT NOT NULL,
  samples_stored INTEGER NOT NULL,
  calibration_toml TEXT NOT NULL,
  result_json TEXT NOT NULL,
  uid TEXT
);
CREATE TABLE IF NOT EXISTS samples (
  event_id INTEGER PRIMARY KEY REFERENCES events(id) ON DELETE CASCADE,
  count INTEGER NOT NULL,
  data BLOB NOT NULL
);
CREATE INDEX IF NOT EXISTS events_created ON events(created_unix_s);
)sql";

/// Stores made before the uid column get it (NULL for their rows).
bool has_uid_column(sqlite3* db) {
  Stmt st(db, "PRAGMA table_info(events)");
  while (sqlite3_step(st.s) == SQLITE_ROW)
    if (st.col_text(1) == "uid") return true;
  return false;
}

/// SQLite says only "unable to open database file"; the system's reason is found first.
void check_path(const std::string& path, bool read_only) {
  namespace fs = std::filesystem;
  const fs::path p(path);
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  std::error_code ec;
  if (!read_only && !fs::exists(dir, ec)) {
    fs::create_directories(dir, ec);
    if (ec)
      throw std::runtime_error(
          fmt::format("{}: cannot create the directory {}: {}", path, dir.string(), ec.message()));
  }
  if (fs::exists(dir, ec) && !fs::is_directory(dir, ec))
    throw std::runtime_error(
        fmt::format("{}: {} is not a directory: {}", path, dir.string(), std::strerror(ENOTDIR)));
  if (::access(dir.c_str(), read_only ? X_OK : (W_OK | X_OK)) != 0)
    throw std::runtime_error(fmt::format("{}: cannot {} in {}: {}", path,
                                         read_only ? "read" : "write", dir.string(),
                                         std::strerror(errno)));
  if (fs::is_directory(p, ec))
    throw std::runtime_error(fmt::format("{}: is a directory, not an event store", path));
  if (fs::exists(p, ec) && ::access(p.c_str(), read_only ? R_OK : (R_OK | W_OK)) != 0)
    throw std::runtime_error(fmt::format("{}: {}", path, std::strerror(errno)));
  if (read_only && !fs::exists(p, ec))
    throw std::runtime_error(fmt::format("{}: no such event store", path));
  // SQLite opens a store whose -wal or -shm it cannot write and fails every commit after: found
  // here, before the daemon says READY.
  for (const char* side : {"-wal", "-shm"}) {
    const std::string f = path + side;
    if (!read_only && fs::exists(f, ec) && ::access(f.c_str(), R_OK | W_OK) != 0)
      throw std::runtime_error(fmt::format("{}: {} (the store's {} file; every commit would fail)",
                                           f, std::strerror(errno), side + 1));
  }
}

/// A log SQLite would replay only in part is copied aside before SQLite opens it: what it held
/// beyond the part SQLite takes is kept for a person to look at, and said loudly.
void keep_damaged_wal(const std::string& path, std::int64_t now_unix_s) {
  const std::string wal = path + "-wal";
  const WalCheck w = check_wal(wal);
  if (!w.present || w.problem.empty()) return;
  const std::string kept = fmt::format("{}.kept-{}", wal, now_unix_s);
  std::error_code ec;
  std::filesystem::copy_file(wal, kept, std::filesystem::copy_options::overwrite_existing, ec);
  spdlog::error(
      "{}: the write-ahead log does not end cleanly: {}; SQLite takes its first {} of {} bytes "
      "({} commit(s)) and drops the rest. {}. Events whose journal files wait in the spill "
      "directory are committed again from them.",
      wal, w.problem, w.used_bytes, w.bytes, w.commits,
      ec ? fmt::format("It could not be copied aside ({}: {})", kept, ec.message())
         : fmt::format("A copy is kept as {}", kept));
}

}  // namespace

EventStore::EventStore(const StoreConfig& c, bool read_only, int busy_timeout_ms) : cfg_(c) {
  check_path(c.path, read_only);
  if (!read_only) keep_damaged_wal(c.path, static_cast<std::int64_t>(std::time(nullptr)));
  const int flags = read_only ? SQLITE_OPEN_READONLY : (SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
  if (sqlite3_open_v2(c.path.c_str(), &db_, flags | SQLITE_OPEN_FULLMUTEX, nullptr) != SQLITE_OK) {
    const std::string msg = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    throw std::runtime_error(fmt::format("{}: cannot open event store: {}", c.path, msg));
  }
  // Opening (the schema) may wait longer for another process than one commit from the loop does.
  sqlite3_busy_timeout(db_, std::max(busy_timeout_ms, 5000));
  try {
    exec(db_, "PRAGMA foreign_keys=ON");
    if (!read_only) {
      exec(db_, "PRAGMA journal_mode=WAL");
      exec(db_, "PRAGMA synchronous=FULL");
      exec(db_, kSchema);
      if (!has_uid_column(db_)) exec(db_, "ALTER TABLE events ADD COLUMN uid TEXT");
      exec(db_, "CREATE INDEX IF NOT EXISTS events_uid ON events(uid)");
      probe_write();
      checkpoint(false);
    }
    sqlite3_busy_timeout(db_, busy_timeout_ms);
  } catch (const std::exception& e) {
    sqlite3_close(db_);
    db_ = nullptr;
    throw std::runtime_error(fmt::format("{}: {}", c.path, e.what()));
  }
}

EventStore::~EventStore() {
  if (writable_) checkpoint(true);
  sqlite3_close(db_);
}

void EventStore::probe_write() {
  // A real write: a store opened read-only underneath (a -shm another user owns, a read-only
  // mount) fails here, not at the first event's commit.
  const int rc = sqlite3_exec(db_,
                              "CREATE TABLE IF NOT EXISTS store_meta (key TEXT PRIMARY KEY, value "
                              "TEXT NOT NULL);"
                              "INSERT OR REPLACE INTO store_meta VALUES ('opened_unix_s', "
                              "strftime('%s','now'))",
                              nullptr, nullptr, nullptr);
  if (rc == SQLITE_BUSY) {
    // Another process holds the write lock: writable, just not now. Events wait for it.
    spdlog::warn("{}: locked by another process at start; events wait until it is released",
                 cfg_.path);
  } else if (rc != SQLITE_OK) {
    throw std::runtime_error(fmt::format("cannot write the event store: {}", sqlite3_errmsg(db_)));
  }
  writable_ = true;
}

void EventStore::checkpoint(bool truncate) {
  int log_frames = 0, done_frames = 0;
  const int rc = sqlite3_wal_checkpoint_v2(
      db_, nullptr, truncate ? SQLITE_CHECKPOINT_TRUNCATE : SQLITE_CHECKPOINT_PASSIVE, &log_frames,
      &done_frames);
  if (rc != SQLITE_OK && rc != SQLITE_BUSY)
    spdlog::warn("{}: checkpoint: {}", cfg_.path, sqlite3_errstr(rc));
}

bool EventStore::disk_low() const {
  struct statvfs v {};
  const auto dir = std::filesystem::path(cfg_.path).parent_path();
  if (::statvfs(dir.empty() ? "." : dir.c_str(), &v) != 0) return false;
  const double free_mb =
      static_cast<double>(v.f_bavail) * static_cast<double>(v.f_frsize) / 1048576.0;
  return free_mb < cfg_.min_free_mb;
}

int EventStore::insert(const EventRecord& r, bool with_samples, std::int64_t& id) {
  int rc = sqlite3_exec(db_, "BEGIN IMMEDIATE", nullptr, nullptr, nullptr);
  if (rc != SQLITE_OK) return rc;
  {
    Stmt st(db_,
            "INSERT INTO events (created_unix_s, source, vehicle_id, pipeline_event_id, bench, "
            "t_start_ns, t_end_ns, end_reason, flags, points, model_hash, samples_stored, "
            "calibration_toml, result_json, uid) VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)");
    st.i64(1, r.created_unix_s);
    st.text(2, r.source);
    st.text(3, r.vehicle_id);
    st.i64(4, r.pipeline_event_id);
    st.text(5, r.bench);
    st.i64(6, r.t_start_ns);
    st.i64(7, r.t_end_ns);
    st.text(8, r.end_reason);
    st.text(9, r.flags);
    st.i64(10, r.points);
    st.text(11, r.model_hash);
    st.i64(12, with_samples ? 1 : 0);
    st.text(13, r.calibration_toml);
    st.text(14, r.result_json);
    st.text(15, r.uid);
    rc = sqlite3_step(st.s);
  }
  if (rc == SQLITE_DONE) {
    id = sqlite3_last_insert_rowid(db_);
    if (with_samples) {
      Stmt st(db_, "INSERT INTO samples (event_id, count, data) VALUES (?,?,?)");
      st.i64(1, id);
      st.i64(2, r.sample_count);
      sqlite3_bind_blob(st.s, 3, r.samples_blob.data(), static_cast<int>(r.samples_blob.size()),
                        SQLITE_TRANSIENT);
      rc = sqlite3_step(st.s);
    }
  }
  if (rc == SQLITE_DONE) rc = sqlite3_exec(db_, "COMMIT", nullptr, nullptr, nullptr);
  if (rc != SQLITE_OK && rc != SQLITE_DONE) {
    sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
    return rc;
  }
  return SQLITE_OK;
}

std::optional<std::int64_t> EventStore::commit(const EventRecord& r, bool* samples_stored) {
  std::int64_t id = 0;
  bool with_samples = cfg_.store_samples && !disk_low();
  if (cfg_.store_samples && !with_samples) degraded_ = true;
  int rc = insert(r, with_samples, id);
  if (rc == SQLITE_FULL && with_samples) {
    degraded_ = true;  // the disk is full: keep the results, stop storing raw samples
    with_samples = false;
    rc = insert(r, false, id);
  }
  if (rc != SQLITE_OK) {
    error_ = fmt::format("{}: cannot store event: {}", cfg_.path, sqlite3_errstr(rc));
    return std::nullopt;
  }
  if (samples_stored) *samples_stored = with_samples;
  // The main file holds every committed event (a backup of events.db alone is whole, and a torn
  // -wal cannot take a committed event with it); PASSIVE never waits for readers.
  checkpoint(false);
  return id;
}

std::optional<std::int64_t> EventStore::commit(
    const pipeline::EventResult& e, const std::string& result_json,
    const std::string& calibration_toml, const std::string& vehicle_id, const std::string& source,
    const std::string& model_hash, std::int64_t now_unix_s, bool* samples_stored) {
  return commit(
      make_record(e, result_json, calibration_toml, vehicle_id, source, model_hash, now_unix_s),
      samples_stored);
}

int EventStore::apply_retention(std::int64_t now_unix_s) {
  const auto cutoff = now_unix_s - static_cast<std::int64_t>(cfg_.retention_days * 86400.0);
  // sqlite3_changes() keeps the last statement that completed: counted only when this one did.
  Stmt a(db_, "DELETE FROM events WHERE created_unix_s < ?");
  a.i64(1, cutoff);
  int n = sqlite3_step(a.s) == SQLITE_DONE ? sqlite3_changes(db_) : 0;
  Stmt b(db_,
         "DELETE FROM events WHERE id NOT IN (SELECT id FROM events ORDER BY id DESC LIMIT ?)");
  b.i64(1, cfg_.max_events);
  if (sqlite3_step(b.s) == SQLITE_DONE) n += sqlite3_changes(db_);
  return n;
}

void EventStore::set_max_pages(int pages) {
  exec(db_, fmt::format("PRAGMA max_page_count={}", pages).c_str());
}

}  // namespace brakefit::daemon
