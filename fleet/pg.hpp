#pragma once
// A thin RAII adapter over libpq: one connection, parameterised statements only (text or binary
// parameters, never spliced into SQL), errors as PgError with the SQLSTATE. The connection string
// is a URL or key=value list; the password never travels in it (see fleet/credentials.hpp).
#include <cstdint>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

struct pg_conn;
struct pg_result;

namespace brakefit::fleet {

class PgError : public std::runtime_error {
 public:
  PgError(const std::string& what, std::string sqlstate)
      : std::runtime_error(what), sqlstate_(std::move(sqlstate)) {}
  /// "" for a connection failure; e.g. "28P01" (bad password), "57014" (statement timeout).
  const std::string& sqlstate() const { return sqlstate_; }
  /// The server refused who we are (bad password, no such role, no pg_hba entry): retrying
  /// without a change will not help.
  bool auth_failure() const;

 private:
  std::string sqlstate_;
};

/// One statement parameter: text, binary (bytea) or NULL.
struct PgParam {
  std::optional<std::string> value;
  bool binary = false;
  static PgParam text(std::string v) { return {std::move(v), false}; }
  static PgParam bytes(std::string v) { return {std::move(v), true}; }
  static PgParam null() { return {std::nullopt, false}; }
};

class PgResult {
 public:
  explicit PgResult(pg_result* r) : r_(r) {}
  ~PgResult();
  PgResult(PgResult&& o) noexcept : r_(o.r_) { o.r_ = nullptr; }
  PgResult(const PgResult&) = delete;
  PgResult& operator=(const PgResult&) = delete;
  PgResult& operator=(PgResult&&) = delete;
  int rows() const;
  int cols() const;
  bool null(int row, int col) const;
  std::string text(int row, int col) const;
  std::string column_name(int col) const;
  /// Rows affected by an INSERT/UPDATE (0 for ON CONFLICT DO NOTHING hits).
  std::int64_t affected() const;

 private:
  pg_result* r_;
};

class Pg {
 public:
  /// Connects; `settings` are libpq keywords that override the URL's (password, sslmode,
  /// connect_timeout, application_name, options). Throws PgError naming the server (without its
  /// password) and libpq's reason.
  Pg(const std::string& url, const std::map<std::string, std::string>& settings = {});
  ~Pg();
  Pg(const Pg&) = delete;
  Pg& operator=(const Pg&) = delete;

  PgResult exec(const std::string& sql, const std::vector<PgParam>& params = {});
  /// Several statements without parameters (migrations).
  void exec_script(const std::string& sql);
  /// COPY ... FROM STDIN with these rows in COPY's text format (append_copy_text() writes a field).
  void copy_in(const std::string& copy_sql, const std::string& rows);
  /// The server as "user@host:port/db" (for logs).
  std::string describe() const;
  bool ssl_in_use() const;

 private:
  pg_conn* c_ = nullptr;
};

/// Appends a field in COPY's text format: backslash, tab, newline and carriage return escaped;
/// nullopt is \N.
void append_copy_text(std::string& out, std::optional<std::string_view> v);

/// True when the URL or key=value string carries a password (refused on a command line).
bool carries_password(const std::string& url);

}  // namespace brakefit::fleet
