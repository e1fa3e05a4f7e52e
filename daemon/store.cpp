#include "daemon/store.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <sqlite3.h>
#include <sys/statvfs.h>

#include <cstring>
#include <filesystem>
#include <stdexcept>

namespace brakefit::daemon {

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
  result_json TEXT NOT NULL
);
CREATE TABLE IF NOT EXISTS samples (
  event_id INTEGER PRIMARY KEY REFERENCES events(id) ON DELETE CASCADE,
  count INTEGER NOT NULL,
  data BLOB NOT NULL
);
CREATE INDEX IF NOT EXISTS events_created ON events(created_unix_s);
)sql";

constexpr std::size_t kRecord = 8 + 4 * 8 + 2;

struct Stmt {
  sqlite3_stmt* s = nullptr;
  Stmt(sqlite3* db, const char* sql) {
    if (sqlite3_prepare_v2(db, sql, -1, &s, nullptr) != SQLITE_OK)
      throw std::runtime_error(fmt::format("sqlite: {}: {}", sql, sqlite3_errmsg(db)));
  }
  ~Stmt() { sqlite3_finalize(s); }
  Stmt(const Stmt&) = delete;
  Stmt& operator=(const Stmt&) = delete;
  void text(int i, const std::string& v) {
    sqlite3_bind_text(s, i, v.c_str(), static_cast<int>(v.size()), SQLITE_TRANSIENT);
  }
  void i64(int i, std::int64_t v) { sqlite3_bind_int64(s, i, v); }
  std::string col_text(int i) const {
    const auto* p = sqlite3_column_text(s, i);
    return p ? reinterpret_cast<const char*>(p) : "";
  }
};

void exec(sqlite3* db, const char* sql) {
  char* err = nullptr;
  if (sqlite3_exec(db, sql, nullptr, nullptr, &err) != SQLITE_OK) {
    const std::string msg = err ? err : "?";
    sqlite3_free(err);
    throw std::runtime_error(fmt::format("sqlite: {}: {}", sql, msg));
  }
}

StoredEvent row(const Stmt& st) {
  StoredEvent e;
  e.id = sqlite3_column_int64(st.s, 0);
  e.created_unix_s = sqlite3_column_int64(st.s, 1);
  e.source = st.col_text(2);
  e.vehicle_id = st.col_text(3);
  e.pipeline_event_id = sqlite3_column_int(st.s, 4);
  e.bench = st.col_text(5);
  e.t_start_ns = sqlite3_column_int64(st.s, 6);
  e.t_end_ns = sqlite3_column_int64(st.s, 7);
  e.end_reason = st.col_text(8);
  e.flags = st.col_text(9);
  e.points = sqlite3_column_int64(st.s, 10);
  e.model_hash = st.col_text(11);
  e.samples_stored = sqlite3_column_int(st.s, 12) != 0;
  e.calibration_toml = st.col_text(13);
  e.result_json = st.col_text(14);
  return e;
}

constexpr const char* kCols =
    "id, created_unix_s, source, vehicle_id, pipeline_event_id, bench, t_start_ns, t_end_ns, "
    "end_reason, flags, points, model_hash, samples_stored, calibration_toml, result_json";

template <typename T>
void put(std::string& out, T v) {
  char b[sizeof v];
  std::memcpy(b, &v, sizeof v);
  out.append(b, sizeof v);
}
template <typename T>
T get(const unsigned char*& p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  p += sizeof v;
  return v;
}

}  // namespace

std::string pack_samples(const std::vector<pipeline::Sample>& s) {
  std::string out;
  out.reserve(s.size() * kRecord);
  for (const auto& x : s) {
    put(out, x.t_ns);
    put(out, x.v_ref_mps);
    put(out, x.v_wheel_mps);
    put(out, x.pressure_bar);
    put(out, x.force_n);
    put(out, static_cast<std::uint8_t>(x.state));
    put(out, static_cast<std::uint8_t>(x.sensor_fault ? 1 : 0));
  }
  return out;
}

std::vector<pipeline::Sample> unpack_samples(const void* data, std::size_t n) {
  std::vector<pipeline::Sample> out;
  const auto* p = static_cast<const unsigned char*>(data);
  for (std::size_t i = 0; i + kRecord <= n; i += kRecord) {
    pipeline::Sample s;
    s.t_ns = get<std::int64_t>(p);
    s.v_ref_mps = get<double>(p);
    s.v_wheel_mps = get<double>(p);
    s.pressure_bar = get<double>(p);
    s.force_n = get<double>(p);
    s.state = static_cast<can::TestState>(get<std::uint8_t>(p));
    s.sensor_fault = get<std::uint8_t>(p) != 0;
    out.push_back(s);
  }
  return out;
}

EventStore::EventStore(const StoreConfig& c, bool read_only) : cfg_(c) {
  if (!read_only) {
    std::error_code ec;
    const auto dir = std::filesystem::path(c.path).parent_path();
    if (!dir.empty()) std::filesystem::create_directories(dir, ec);
  }
  const int flags = read_only ? SQLITE_OPEN_READONLY : (SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
  if (sqlite3_open_v2(c.path.c_str(), &db_, flags | SQLITE_OPEN_FULLMUTEX, nullptr) != SQLITE_OK) {
    const std::string msg = db_ ? sqlite3_errmsg(db_) : "out of memory";
    sqlite3_close(db_);
    db_ = nullptr;
    throw std::runtime_error(fmt::format("{}: cannot open event store: {}", c.path, msg));
  }
  sqlite3_busy_timeout(db_, 2000);
  try {
    exec(db_, "PRAGMA foreign_keys=ON");
    if (!read_only) {
      exec(db_, "PRAGMA journal_mode=WAL");
      exec(db_, "PRAGMA synchronous=FULL");
      exec(db_, kSchema);
    }
  } catch (const std::exception& e) {
    sqlite3_close(db_);
    db_ = nullptr;
    throw std::runtime_error(fmt::format("{}: {}", c.path, e.what()));
  }
}

EventStore::~EventStore() {
  sqlite3_close(db_);
}

bool EventStore::disk_low() const {
  struct statvfs v {};
  const auto dir = std::filesystem::path(cfg_.path).parent_path();
  if (::statvfs(dir.empty() ? "." : dir.c_str(), &v) != 0) return false;
  const double free_mb =
      static_cast<double>(v.f_bavail) * static_cast<double>(v.f_frsize) / 1048576.0;
  return free_mb < cfg_.min_free_mb;
}

int EventStore::insert(const pipeline::EventResult& e, const std::string& result_json,
                       const std::string& calibration_toml, const std::string& vehicle_id,
                       const std::string& source, const std::string& model_hash, std::int64_t now,
                       bool with_samples, std::int64_t& id) {
  int rc = sqlite3_exec(db_, "BEGIN IMMEDIATE", nullptr, nullptr, nullptr);
  if (rc != SQLITE_OK) return rc;
  {
    Stmt st(db_,
            "INSERT INTO events (created_unix_s, source, vehicle_id, pipeline_event_id, bench, "
            "t_start_ns, t_end_ns, end_reason, flags, points, model_hash, samples_stored, "
            "calibration_toml, result_json) VALUES (?,?,?,?,?,?,?,?,?,?,?,?,?,?)");
    st.i64(1, now);
    st.text(2, source);
    st.text(3, vehicle_id);
    st.i64(4, e.event.event_id);
    st.text(5, can::to_string(e.event.bench));
    st.i64(6, e.event.t_start_ns);
    st.i64(7, e.event.t_end_ns);
    st.text(8, e.event.end_reason);
    st.text(9, fmt::format("{}", fmt::join(e.event.flags, ",")));
    st.i64(10, static_cast<std::int64_t>(e.curve.size()));
    st.text(11, model_hash);
    st.i64(12, with_samples ? 1 : 0);
    st.text(13, calibration_toml);
    st.text(14, result_json);
    rc = sqlite3_step(st.s);
  }
  if (rc == SQLITE_DONE) {
    id = sqlite3_last_insert_rowid(db_);
    if (with_samples) {
      const std::string blob = pack_samples(e.event.samples);
      Stmt st(db_, "INSERT INTO samples (event_id, count, data) VALUES (?,?,?)");
      st.i64(1, id);
      st.i64(2, static_cast<std::int64_t>(e.event.samples.size()));
      sqlite3_bind_blob(st.s, 3, blob.data(), static_cast<int>(blob.size()), SQLITE_TRANSIENT);
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

std::optional<std::int64_t> EventStore::commit(
    const pipeline::EventResult& e, const std::string& result_json,
    const std::string& calibration_toml, const std::string& vehicle_id, const std::string& source,
    const std::string& model_hash, std::int64_t now_unix_s, bool* samples_stored) {
  std::int64_t id = 0;
  bool with_samples = cfg_.store_samples && !disk_low();
  if (cfg_.store_samples && !with_samples) degraded_ = true;
  int rc = insert(e, result_json, calibration_toml, vehicle_id, source, model_hash, now_unix_s,
                  with_samples, id);
  if (rc == SQLITE_FULL && with_samples) {
    degraded_ = true;  // the disk is full: keep the results, stop storing raw samples
    with_samples = false;
    rc = insert(e, result_json, calibration_toml, vehicle_id, source, model_hash, now_unix_s, false,
                id);
  }
  if (rc != SQLITE_OK) {
    error_ = fmt::format("{}: cannot store event: {}", cfg_.path, sqlite3_errstr(rc));
    return std::nullopt;
  }
  if (samples_stored) *samples_stored = with_samples;
  return id;
}

int EventStore::apply_retention(std::int64_t now_unix_s) {
  const auto cutoff = now_unix_s - static_cast<std::int64_t>(cfg_.retention_days * 86400.0);
  Stmt a(db_, "DELETE FROM events WHERE created_unix_s < ?");
  a.i64(1, cutoff);
  sqlite3_step(a.s);
  int n = sqlite3_changes(db_);
  Stmt b(db_,
         "DELETE FROM events WHERE id NOT IN (SELECT id FROM events ORDER BY id DESC LIMIT ?)");
  b.i64(1, cfg_.max_events);
  sqlite3_step(b.s);
  n += sqlite3_changes(db_);
  return n;
}

std::vector<StoredEvent> EventStore::list(int limit) const {
  Stmt st(db_, fmt::format("SELECT {} FROM events ORDER BY id DESC LIMIT ?", kCols).c_str());
  st.i64(1, limit);
  std::vector<StoredEvent> out;
  while (sqlite3_step(st.s) == SQLITE_ROW) out.push_back(row(st));
  return out;
}

std::optional<StoredEvent> EventStore::get(std::int64_t id) const {
  Stmt st(db_, fmt::format("SELECT {} FROM events WHERE id = ?", kCols).c_str());
  st.i64(1, id);
  if (sqlite3_step(st.s) != SQLITE_ROW) return std::nullopt;
  return row(st);
}

std::vector<pipeline::Sample> EventStore::samples(std::int64_t id) const {
  Stmt st(db_, "SELECT data FROM samples WHERE event_id = ?");
  st.i64(1, id);
  if (sqlite3_step(st.s) != SQLITE_ROW) return {};
  return unpack_samples(sqlite3_column_blob(st.s, 0),
                        static_cast<std::size_t>(sqlite3_column_bytes(st.s, 0)));
}

std::int64_t EventStore::count() const {
  Stmt st(db_, "SELECT COUNT(*) FROM events");
  sqlite3_step(st.s);
  return sqlite3_column_int64(st.s, 0);
}

std::string EventStore::integrity_check() const {
  Stmt st(db_, "PRAGMA integrity_check");
  std::string out;
  while (sqlite3_step(st.s) == SQLITE_ROW) {
    if (!out.empty()) out.push_back('\n');
    out.append(st.col_text(0));
  }
  return out;
}

void EventStore::set_max_pages(int pages) {
  exec(db_, fmt::format("PRAGMA max_page_count={}", pages).c_str());
}

}  // namespace brakefit::daemon
