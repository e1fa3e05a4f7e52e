#include "fleet/pg.hpp"

#include <fmt/format.h>
#include <libpq-fe.h>

#include <algorithm>
#include <regex>

namespace brakefit::fleet {

bool PgError::auth_failure() const {
  // 28xxx: invalid authorization specification / password; 42501: insufficient privilege.
  return sqlstate_.rfind("28", 0) == 0 || sqlstate_ == "42501";
}

PgResult::~PgResult() {
  PQclear(r_);
}
int PgResult::rows() const {
  return PQntuples(r_);
}
int PgResult::cols() const {
  return PQnfields(r_);
}
bool PgResult::null(int row, int col) const {
  return PQgetisnull(r_, row, col) != 0;
}
std::string PgResult::text(int row, int col) const {
  return std::string(PQgetvalue(r_, row, col), static_cast<std::size_t>(PQgetlength(r_, row, col)));
}
std::string PgResult::column_name(int col) const {
  return PQfname(r_, col);
}
std::int64_t PgResult::affected() const {
  const char* n = PQcmdTuples(r_);
  return n && *n ? std::stoll(n) : 0;
}

namespace {

/// libpq's multi-line messages, on one log line.
std::string one_line(std::string m) {
  while (!m.empty() && (m.back() == '\n' || m.back() == ' ')) m.pop_back();
  for (auto& ch : m)
    if (ch == '\n') ch = ' ';
  return m;
}

std::string conn_error(pg_conn* c) {
  return one_line(PQerrorMessage(c));
}

/// Throws PgError for a failed statement (with its SQLSTATE), else hands the result over.
PgResult checked(pg_conn* c, pg_result* r) {
  const ExecStatusType st = r ? PQresultStatus(r) : PGRES_FATAL_ERROR;
  if (st == PGRES_COMMAND_OK || st == PGRES_TUPLES_OK) return PgResult(r);
  std::string state;
  std::string msg = r ? PQresultErrorMessage(r) : "";
  if (r) {
    if (const char* s = PQresultErrorField(r, PG_DIAG_SQLSTATE)) state = s;
    PQclear(r);
  }
  throw PgError(msg.empty() ? conn_error(c) : one_line(msg), state);
}

}  // namespace

Pg::Pg(const std::string& url, const std::map<std::string, std::string>& settings) {
  std::vector<const char*> keys{"dbname"}, values{url.c_str()};
  for (const auto& [k, v] : settings) {
    keys.push_back(k.c_str());
    values.push_back(v.c_str());
  }
  keys.push_back(nullptr);
  values.push_back(nullptr);
  c_ = PQconnectdbParams(keys.data(), values.data(), 1);
  if (PQstatus(c_) != CONNECTION_OK) {
    const std::string why = conn_error(c_);
    PQfinish(c_);
    c_ = nullptr;
    // The SQLSTATE of a failed connection is not exposed; a refused password says so in words.
    const bool auth = why.find("password authentication failed") != std::string::npos ||
                      why.find("no pg_hba.conf entry") != std::string::npos ||
                      why.find("does not exist") != std::string::npos;
    throw PgError(fmt::format("cannot connect to the central server: {}", why),
                  auth ? "28P01" : "");
  }
  // The server's NOTICEs ("already exists, skipping") are not the user's business.
  PQsetNoticeProcessor(
      c_, [](void*, const char*) {}, nullptr);
}

Pg::~Pg() {
  PQfinish(c_);
}

PgResult Pg::exec(const std::string& sql, const std::vector<PgParam>& params) {
  std::vector<const char*> values;
  std::vector<int> lengths, formats;
  for (const auto& p : params) {
    values.push_back(p.value ? p.value->data() : nullptr);
    lengths.push_back(p.value ? static_cast<int>(p.value->size()) : 0);
    formats.push_back(p.binary ? 1 : 0);
  }
  return checked(c_, PQexecParams(c_, sql.c_str(), static_cast<int>(params.size()), nullptr,
                                  values.data(), lengths.data(), formats.data(), 0));
}

void Pg::exec_script(const std::string& sql) {
  checked(c_, PQexec(c_, sql.c_str()));
}

void Pg::copy_in(const std::string& copy_sql, const std::string& rows) {
  pg_result* start = PQexec(c_, copy_sql.c_str());
  if (!start || PQresultStatus(start) != PGRES_COPY_IN) {
    checked(c_, start);  // throws with the server's reason
    throw PgError("COPY did not start", "");
  }
  PQclear(start);
  // In 64 kB messages: the server holds a whole message in memory before it parses it, and a
  // batch sent as one (megabytes) was allocated and page-faulted afresh by every batch.
  constexpr std::size_t kChunk = 64 * 1024;
  for (std::size_t at = 0; at < rows.size(); at += kChunk) {
    const std::size_t n = std::min(kChunk, rows.size() - at);
    if (PQputCopyData(c_, rows.data() + at, static_cast<int>(n)) != 1)
      throw PgError(fmt::format("COPY: {}", conn_error(c_)), "");
  }
  if (PQputCopyEnd(c_, nullptr) != 1) throw PgError(fmt::format("COPY: {}", conn_error(c_)), "");
  // The COPY's own result, then the end of the results.
  checked(c_, PQgetResult(c_));
  while (pg_result* more = PQgetResult(c_)) PQclear(more);
}

void append_copy_text(std::string& out, std::optional<std::string_view> v) {
  if (!v) {
    out += "\\N";
    return;
  }
  // Runs without a special character are appended whole: the text of a result is kilobytes with
  // hardly an escape in it.
  const std::string_view text = *v;
  std::size_t from = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    char escaped = 0;
    switch (text[i]) {
      case '\\':
        escaped = '\\';
        break;
      case '\t':
        escaped = 't';
        break;
      case '\n':
        escaped = 'n';
        break;
      case '\r':
        escaped = 'r';
        break;
      default:
        continue;
    }
    out.append(text.substr(from, i - from));
    out += '\\';
    out += escaped;
    from = i + 1;
  }
  out.append(text.substr(from));
}

std::string Pg::describe() const {
  return fmt::format("{}@{}:{}/{}", PQuser(c_), PQhost(c_), PQport(c_), PQdb(c_));
}

bool Pg::ssl_in_use() const {
  return PQsslInUse(c_) != 0;
}

bool carries_password(const std::string& url) {
  static const std::regex url_pw(R"(^postgres(ql)?://[^/@:]*:[^/@]*@)");
  static const std::regex kv_pw(R"((^|[\s?&])password\s*=)");
  return std::regex_search(url, url_pw) || std::regex_search(url, kv_pw);
}

}  // namespace brakefit::fleet
