// brakefit events list|show|export: reads brakefitd's event store (read-only).
#include <fmt/format.h>

#include <ctime>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "brakefit/version.hpp"
#include "cli/commands.hpp"
#include "cli/io.hpp"
#include "core/pipeline/event_csv.hpp"
#include "daemon/store.hpp"
#include "fleet/sync.hpp"

namespace brakefit::cli {

namespace {

std::unique_ptr<daemon::EventStore> open_store(const std::string& path) {
  if (!std::filesystem::exists(path))
    throw ExitError(kExitNoInput, fmt::format("{}: no event store here", path));
  daemon::StoreConfig c;
  c.path = path;
  try {
    return std::make_unique<daemon::EventStore>(c, true);
  } catch (const std::exception& e) {
    throw ExitError(kExitDataError, e.what());
  }
}

daemon::StoredEvent get_event(const daemon::EventStore& s, const std::string& path,
                              std::int64_t id) {
  auto e = s.get(id);
  if (!e) throw ExitError(kExitDataError, fmt::format("{}: no event with id {}", path, id));
  return *e;
}

nlohmann::ordered_json stored_json(const daemon::StoredEvent& e) {
  nlohmann::ordered_json j;
  j["schema"] = "brakefit.stored_event/1";
  j["version"] = kVersion;
  j["id"] = e.id;
  j["created"] = iso8601_utc(e.created_unix_s);
  j["created_unix_s"] = e.created_unix_s;
  j["vehicle_id"] = e.vehicle_id;
  j["source"] = e.source;
  j["samples_stored"] = e.samples_stored;
  j["model_hash"] =
      e.model_hash.empty() ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(e.model_hash);
  j["event"] = nlohmann::ordered_json::parse(e.result_json, nullptr, false);
  return j;
}

}  // namespace

void add_events_command(CLI::App& app) {
  struct Opts {
    std::string db = "/var/lib/brakefit/events.db", out;
    int limit = 50;
    std::int64_t id = 0;
    bool json = false;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand("events", "Read brakefitd's event store");
  cmd->require_subcommand(1);
  cmd->add_option("--db", o->db, "event store (SQLite); before or after the subcommand")
      ->capture_default_str();

  auto* list = cmd->add_subcommand("list", "The newest events, one line each");
  list->add_option("--limit", o->limit, "how many")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000000));
  list->add_flag("--json", o->json, "one brakefit.stored_event/1 document per line");
  list->fallthrough();  // --db after `list` too
  list->callback([o] {
    auto s = open_store(o->db);
    const auto events = s->list(o->limit);
    // brakefit sync's status beside the store, when a sync runs for it.
    if (const std::string sync = fleet::status_line(fleet::default_status_path(o->db));
        !o->json && !sync.empty())
      std::cout << sync << "\n";
    if (!o->json)
      std::cout << fmt::format("{:>6}  {:<20}  {:<16}  {:<6}  {:<15}  {:<14}  {:>5}  {}\n", "id",
                               "created (UTC)", "vehicle", "bench", "end", "flags", "pts",
                               "hybrid B C D E (basis)");
    for (const auto& e : events) {
      if (o->json) {
        std::cout << stored_json(e).dump() << "\n";
        continue;
      }
      std::string fit = "-";
      const auto doc = nlohmann::json::parse(e.result_json, nullptr, false);
      // The published fits: the tyre's when the event has them (a bench measurement model).
      const char* key = doc.is_object() && doc.contains("tyre_results") &&
                                doc["tyre_results"].is_array() && !doc["tyre_results"].empty()
                            ? "tyre_results"
                            : "results";
      if (doc.is_object() && doc.contains(key))
        for (const auto& r : doc[key])
          if (r.is_object() && r.contains("method") && r["method"] == "hybrid" && r.contains("B") &&
              r["B"].is_number())
            fit = fmt::format("{:.3f} {:.4f} {:.1f} {:.4f} ({})", r["B"].get<double>(),
                              r["C"].get<double>(), r["D"].get<double>(), r["E"].get<double>(),
                              key == std::string("tyre_results") ? "tyre" : "instrument");
      std::cout << fmt::format("{:>6}  {:<20}  {:<16}  {:<6}  {:<15}  {:<14}  {:>5}  {}\n", e.id,
                               iso8601_utc(e.created_unix_s),
                               e.vehicle_id.empty() ? "-" : e.vehicle_id, e.bench, e.end_reason,
                               e.flags.empty() ? "-" : e.flags, e.points, fit);
    }
  });

  auto* show = cmd->add_subcommand("show", "One event: results and provenance as JSON");
  show->add_option("id", o->id, "event id")->required();
  show->fallthrough();
  show->callback([o] {
    auto s = open_store(o->db);
    std::cout << stored_json(get_event(*s, o->db, o->id)).dump(2) << "\n";
  });

  auto* exp = cmd->add_subcommand("export", "One event's raw samples as an event CSV");
  exp->add_option("id", o->id, "event id")->required();
  exp->fallthrough();
  exp->add_option("--out", o->out, "CSV file (brakefit replay/gap read it)")->required();
  exp->callback([o] {
    auto s = open_store(o->db);
    const auto e = get_event(*s, o->db, o->id);
    if (!e.samples_stored)
      throw ExitError(
          kExitDataError,
          fmt::format("{}: event {} has no raw samples (the store was degraded)", o->db, o->id));
    pipeline::Event ev;
    ev.event_id = e.pipeline_event_id;
    ev.t_start_ns = e.t_start_ns;
    ev.t_end_ns = e.t_end_ns;
    ev.end_reason = e.end_reason;
    ev.samples = s->samples(e.id);
    const auto cal = pipeline::parse_calibration(e.calibration_toml, o->db + ":calibration");
    ev.bench = cal.bench;
    write_file(o->out, pipeline::format_event_csv(ev, cal));
    std::cout << fmt::format("event {}: {} samples -> {}\n", e.id, ev.samples.size(), o->out);
  });
}

}  // namespace brakefit::cli
