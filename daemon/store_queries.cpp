// The event store's queries: events by id, uid, age and order, their samples, counts, and
// SQLite's integrity check. The write side (open, commit, retention) is store.cpp.
#include <sqlite3.h>

#include <optional>
#include <string>
#include <vector>

#include "daemon/store.hpp"
#include "daemon/store_sql.hpp"

namespace brakefit::daemon {

using sql::kCols;
using sql::row;
using sql::Stmt;

std::optional<std::int64_t> EventStore::find(const EventRecord& r) const {
  Stmt st(db_, "SELECT id FROM events WHERE uid = ?");
  st.text(1, r.uid);
  if (sqlite3_step(st.s) != SQLITE_ROW) return std::nullopt;
  return sqlite3_column_int64(st.s, 0);
}

std::optional<StoredEvent> EventStore::last() const {
  Stmt st(db_, fmt::format("SELECT {} FROM events ORDER BY id DESC LIMIT 1", kCols).c_str());
  if (sqlite3_step(st.s) != SQLITE_ROW) return std::nullopt;
  return row(st);
}

std::vector<StoredEvent> EventStore::list(int limit) const {
  Stmt st(db_, fmt::format("SELECT {} FROM events ORDER BY id DESC LIMIT ?", kCols).c_str());
  st.i64(1, limit);
  std::vector<StoredEvent> out;
  while (sqlite3_step(st.s) == SQLITE_ROW) out.push_back(row(st));
  return out;
}

std::vector<StoredEvent> EventStore::after(std::int64_t after_id, std::int64_t min_created_unix_s,
                                           int limit) const {
  Stmt st(db_, fmt::format("SELECT {} FROM events WHERE id > ? AND created_unix_s >= ? ORDER BY id "
                           "LIMIT ?",
                           kCols)
                   .c_str());
  st.i64(1, after_id);
  st.i64(2, min_created_unix_s);
  st.i64(3, limit);
  std::vector<StoredEvent> out;
  while (sqlite3_step(st.s) == SQLITE_ROW) out.push_back(row(st));
  return out;
}

std::int64_t EventStore::count_after(std::int64_t after_id, std::int64_t min_created_unix_s) const {
  Stmt st(db_, "SELECT COUNT(*) FROM events WHERE id > ? AND created_unix_s >= ?");
  st.i64(1, after_id);
  st.i64(2, min_created_unix_s);
  sqlite3_step(st.s);
  return sqlite3_column_int64(st.s, 0);
}

std::string EventStore::samples_blob(std::int64_t id, std::int64_t* count) const {
  Stmt st(db_, "SELECT data, count FROM samples WHERE event_id = ?");
  st.i64(1, id);
  if (sqlite3_step(st.s) != SQLITE_ROW) return {};
  if (count) *count = sqlite3_column_int64(st.s, 1);
  const auto* p = static_cast<const char*>(sqlite3_column_blob(st.s, 0));
  return p ? std::string(p, static_cast<std::size_t>(sqlite3_column_bytes(st.s, 0)))
           : std::string();
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

}  // namespace brakefit::daemon
