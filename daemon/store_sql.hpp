// The event store's SQL plumbing shared by its write side (store.cpp) and its queries
// (store_queries.cpp): a prepared statement, a statement run once, an events row.
#pragma once

#include <fmt/format.h>
#include <sqlite3.h>

#include <cstdint>
#include <stdexcept>
#include <string>

#include "daemon/store.hpp"

namespace brakefit::daemon::sql {

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

inline void exec(sqlite3* db, const char* sql) {
  char* err = nullptr;
  if (sqlite3_exec(db, sql, nullptr, nullptr, &err) != SQLITE_OK) {
    const std::string msg = err ? err : "?";
    sqlite3_free(err);
    throw std::runtime_error(fmt::format("sqlite: {}: {}", sql, msg));
  }
}

/// The events columns in the order row() reads them.
inline constexpr const char* kCols =
    "id, created_unix_s, source, vehicle_id, pipeline_event_id, bench, t_start_ns, t_end_ns, "
    "end_reason, flags, points, model_hash, samples_stored, calibration_toml, result_json, uid";

inline StoredEvent row(const Stmt& st) {
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
  e.uid = st.col_text(15);
  return e;
}

}  // namespace brakefit::daemon::sql
