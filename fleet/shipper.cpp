#include "fleet/shipper.hpp"

#include <fmt/format.h>

#include <cmath>
#include <ctime>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <optional>
#include <string_view>
#include <set>

#include "core/pipeline/calibration.hpp"

namespace brakefit::fleet {

namespace {

constexpr std::size_t kColumns = 20;

PgParam maybe(double v) {
  return std::isfinite(v) ? PgParam::text(fmt::format("{:.17g}", v)) : PgParam::null();
}

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
  std::set<std::pair<int, int>> months;
  for (const auto& e : events) {
    const auto t = static_cast<std::time_t>(e.created_unix_s);
    std::tm tm{};
    gmtime_r(&t, &tm);
    if (months.insert({tm.tm_year, tm.tm_mon}).second)
      pg.exec("SELECT brakefit.ensure_month(to_timestamp($1))",
              {PgParam::text(std::to_string(e.created_unix_s))});
  }
  std::string sql =
      "INSERT INTO brakefit.events (station_id, lane_id, event_uid, created_at, store_row_id, "
      "source, vehicle_id, bench, end_reason, flags, points, model_hash, calibration_toml, result, "
      "wheel_load_n, peak_friction, slip_stiffness_n, fit_method, samples, samples_count) VALUES ";
  std::vector<PgParam> params;
  params.reserve(events.size() * kColumns);
  for (std::size_t i = 0; i < events.size(); ++i) {
    const auto& e = events[i];
    const EventFigures f = figures_of(e);
    std::int64_t count = 0;
    const std::string blob =
        with_samples && e.samples_stored ? store.samples_blob(e.id, &count) : "";
    const std::size_t b = params.size();
    sql += fmt::format(
        "{}(${},${},${},to_timestamp(${}),${},${},${},${},${},${},${},${},${},${}::jsonb,${},${},"
        "${},${},${},${})",
        i ? "," : "", b + 1, b + 2, b + 3, b + 4, b + 5, b + 6, b + 7, b + 8, b + 9, b + 10, b + 11,
        b + 12, b + 13, b + 14, b + 15, b + 16, b + 17, b + 18, b + 19, b + 20);
    params.push_back(PgParam::text(ids.station));
    params.push_back(PgParam::text(ids.lane));
    params.push_back(PgParam::text(uid_of(e)));
    params.push_back(PgParam::text(std::to_string(e.created_unix_s)));
    params.push_back(PgParam::text(std::to_string(e.id)));
    params.push_back(PgParam::text(e.source));
    params.push_back(PgParam::text(e.vehicle_id));
    params.push_back(PgParam::text(e.bench));
    params.push_back(PgParam::text(e.end_reason));
    params.push_back(PgParam::text(e.flags));
    params.push_back(PgParam::text(std::to_string(e.points)));
    params.push_back(PgParam::text(e.model_hash));
    params.push_back(PgParam::text(e.calibration_toml));
    params.push_back(PgParam::text(e.result_json));
    params.push_back(maybe(f.wheel_load_n));
    params.push_back(maybe(f.peak_friction));
    params.push_back(maybe(f.slip_stiffness_n));
    params.push_back(f.method.empty() ? PgParam::null() : PgParam::text(f.method));
    params.push_back(blob.empty() ? PgParam::null() : PgParam::bytes(blob));
    params.push_back(count > 0 ? PgParam::text(std::to_string(count)) : PgParam::null());
    out.last_row_id = e.id;
  }
  sql += " ON CONFLICT (event_uid, created_at) DO NOTHING";
  const PgResult r = pg.exec(sql, params);
  out.sent = events.size();
  out.inserted = static_cast<std::size_t>(r.affected());
  return out;
}

}  // namespace brakefit::fleet
