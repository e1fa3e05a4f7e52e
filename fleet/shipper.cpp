#include "fleet/shipper.hpp"

#include <fmt/format.h>

#include <cmath>
#include <cstdlib>
#include <ctime>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string_view>

#include "core/pipeline/calibration.hpp"
#include "fleet/utc_text.hpp"

namespace brakefit::fleet {

namespace {

struct Picked {
  std::string method;
  double b = NAN, c = NAN, d = NAN;
};

/// The number after `"key":` from pos on (NaN when absent or null).
double number_after(std::string_view doc, std::string_view key, std::size_t from, std::size_t to) {
  const std::string k = fmt::format("\"{}\":", key);
  const std::size_t at = doc.find(k, from);
  if (at == std::string_view::npos || at >= to) return NAN;
  const char* p = doc.data() + at + k.size();
  char* end = nullptr;
  const double v = std::strtod(p, &end);
  return end == p ? NAN : v;
}

/// The hybrid fit's (else least squares') B, C, D from a brakefit.event/1 document. The document
/// is brakefit's own (event_json.cpp writes "method" first in each result), so the numbers are
/// found by key after the method's entry: the full parse took most of the sync's time per event.
std::optional<Picked> pick_parsed(std::string_view doc) {
  const auto j = nlohmann::json::parse(doc, nullptr, false);
  if (j.is_discarded() || !j.contains("results") || !j["results"].is_array()) return std::nullopt;
  for (const char* m : {"hybrid", "lm"})
    for (const auto& r : j["results"])
      if (r.value("method", "") == m && r.contains("D") && r["D"].is_number()) {
        auto num = [&r](const char* k) { return r[k].is_number() ? r[k].get<double>() : NAN; };
        return Picked{m, num("B"), num("C"), num("D")};
      }
  return std::nullopt;
}

std::optional<Picked> pick_fit(std::string_view doc) {
  const std::size_t results = doc.find("\"results\":[");
  // Not brakefit's compact writing (a document edited by hand, say): the full parse.
  if (results == std::string_view::npos) return pick_parsed(doc);
  const std::size_t tyre = doc.find("\"tyre_results\":", results);
  const std::size_t limit = tyre == std::string_view::npos ? doc.size() : tyre;
  for (const char* m : {"hybrid", "lm"}) {
    const std::size_t at = doc.find(fmt::format("{{\"method\":\"{}\"", m), results);
    if (at == std::string_view::npos || at >= limit) continue;
    const std::size_t next = std::min(doc.find("{\"method\":", at + 1), limit);
    Picked p{m, number_after(doc, "B", at, next), number_after(doc, "C", at, next),
             number_after(doc, "D", at, next)};
    if (std::isfinite(p.d)) return p;
  }
  return pick_parsed(doc);
}

}  // namespace

std::int64_t resume_unix_s(Pg& pg, const StationIds& ids) {
  const PgResult r = pg.exec(
      "SELECT COALESCE(EXTRACT(EPOCH FROM max(created_at))::bigint, 0) FROM brakefit.events "
      "WHERE station_id = $1 AND lane_id = $2",
      {PgParam::text(ids.station), PgParam::text(ids.lane)});
  const std::int64_t newest = std::stoll(r.text(0, 0));
  return newest > 0 ? std::max<std::int64_t>(0, newest - kResumeMarginS) : 0;
}

std::string uid_of(const daemon::StoredEvent& e) {
  if (!e.uid.empty()) return e.uid;
  return fmt::format("legacy:{}:{}:{}:{}", e.source, e.t_start_ns, e.pipeline_event_id,
                     e.created_unix_s);
}

EventFigures figures_of(const daemon::StoredEvent& e) {
  EventFigures f;
  // A lane's events share their calibration: its TOML is parsed once, not per event.
  thread_local std::string last_toml;
  thread_local double last_load_n = NAN;
  if (e.calibration_toml != last_toml) {
    last_toml = e.calibration_toml;
    try {
      last_load_n = pipeline::parse_calibration(e.calibration_toml, "calibration").wheel_load_n;
    } catch (const std::exception&) {
      // A calibration this version cannot read: the event still ships, without the figures.
      last_load_n = NAN;
    }
  }
  f.wheel_load_n = last_load_n;
  const auto picked = pick_fit(e.result_json);
  if (!picked) return f;
  f.method = picked->method;
  if (f.wheel_load_n > 0) f.peak_friction = picked->d / f.wheel_load_n;
  f.slip_stiffness_n = picked->b * picked->c * picked->d;
  return f;
}

BatchOutcome ship_batch(Pg& pg, const StationIds& ids,
                        const std::vector<daemon::StoredEvent>& events,
                        const daemon::EventStore& store, bool with_samples) {
  BatchOutcome out;
  if (events.empty()) return out;
  // The months' partitions first, each in its own short statement: creating one locks the
  // parent table, which must not wait on this batch's insert.
  std::set<std::string> months;
  for (const auto& e : events) {
    if (months.insert(utc_text(e.created_unix_s, "%Y-%m")).second)
      pg.exec("SELECT brakefit.ensure_month(to_timestamp($1))",
              {PgParam::text(std::to_string(e.created_unix_s))});
  }
  // COPY into a session's temporary table, then one INSERT ... SELECT: a batch is parsed as a
  // stream, not planned as a statement of thousands of parameters (which cost the server more
  // than the rows themselves). BEGIN ... COMMIT makes the batch one transaction.
  constexpr const char* kCols =
      "station_id, lane_id, event_uid, created_at, store_row_id, source, vehicle_id, bench, "
      "end_reason, flags, points, model_hash, calibration_toml, result, wheel_load_n, "
      "peak_friction, slip_stiffness_n, fit_method, samples, samples_count";
  std::string rows;
  std::size_t text_bytes = 0;
  for (const auto& e : events)
    text_bytes += e.result_json.size() + e.calibration_toml.size() + e.flags.size() + 256;
  rows.reserve(text_bytes + text_bytes / 16);
  auto field = [&rows](std::optional<std::string_view> v, bool last = false) {
    append_copy_text(rows, v);
    rows += last ? '\n' : '\t';
  };
  auto number = [](double v) -> std::optional<std::string> {
    if (!std::isfinite(v)) return std::nullopt;
    return fmt::format("{:.17g}", v);
  };
  for (const auto& e : events) {
    const EventFigures f = figures_of(e);
    std::int64_t count = 0;
    const std::string blob =
        with_samples && e.samples_stored ? store.samples_blob(e.id, &count) : std::string();
    field(ids.station);
    field(ids.lane);
    field(uid_of(e));
    field(utc_text(e.created_unix_s, "%Y-%m-%d %H:%M:%S+00"));
    field(std::to_string(e.id));
    field(e.source);
    field(e.vehicle_id);
    field(e.bench);
    field(e.end_reason);
    field(e.flags);
    field(std::to_string(e.points));
    field(e.model_hash);
    field(e.calibration_toml);
    field(e.result_json);
    field(number(f.wheel_load_n));
    field(number(f.peak_friction));
    field(number(f.slip_stiffness_n));
    field(f.method.empty() ? std::nullopt : std::optional<std::string_view>(f.method));
    if (blob.empty()) {
      field(std::nullopt);
      field(std::nullopt, true);
    } else {
      // bytea's hex input, its backslash escaped for COPY, written in place: a blob is large.
      static constexpr char kHex[] = "0123456789abcdef";
      rows += "\\\\x";
      for (unsigned char ch : blob) {
        rows += kHex[ch >> 4];
        rows += kHex[ch & 15];
      }
      rows += '\t';
      field(std::to_string(count), true);
    }
    out.last_row_id = e.id;
  }
  pg.exec("BEGIN");
  try {
    pg.exec(
        "CREATE TEMP TABLE IF NOT EXISTS incoming (LIKE brakefit.events INCLUDING DEFAULTS "
        "INCLUDING COMPRESSION) ON COMMIT DELETE ROWS");
    pg.copy_in(fmt::format("COPY incoming ({}) FROM STDIN", kCols), rows);
    const PgResult r =
        pg.exec(fmt::format("INSERT INTO brakefit.events ({0}) SELECT {0} FROM "
                            "incoming ON CONFLICT (event_uid, created_at) DO NOTHING",
                            kCols));
    pg.exec("COMMIT");
    out.inserted = static_cast<std::size_t>(r.affected());
  } catch (...) {
    try {
      pg.exec("ROLLBACK");
    } catch (const PgError&) {
      // The connection is gone: the server rolls the transaction back itself.
    }
    throw;
  }
  out.sent = events.size();
  return out;
}

}  // namespace brakefit::fleet
