#include "fleet/sync.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <systemd/sd-daemon.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <thread>

#include "brakefit/version.hpp"
#include "fleet/utc_text.hpp"

namespace brakefit::fleet {

namespace {

std::int64_t now_s() {
  return std::chrono::duration_cast<std::chrono::seconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

std::string iso(std::int64_t t) {
  return t <= 0 ? std::string("never") : utc_text(t, "%Y-%m-%dT%H:%M:%SZ");
}

void write_atomically(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp, std::ios::trunc);
    f << text;
    if (!f) return;  // a status file is a convenience: the log says the same
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
}

/// Sleeps up to s seconds in short naps, returning early when asked to stop.
void nap(double s, const SyncOptions& o) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(s);
  while (std::chrono::steady_clock::now() < until) {
    if (o.stop && o.stop()) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
}

}  // namespace

std::string default_status_path(const std::string& store_path) {
  return store_path + ".sync.json";
}

std::string status_json(const SyncStatus& s, const SyncOptions& o) {
  nlohmann::ordered_json j;
  j["schema"] = "brakefit.sync_status/1";
  j["version"] = kVersion;
  j["station"] = o.ids.station;
  j["lane"] = o.ids.lane;
  j["state"] = s.state;
  j["backlog"] = s.backlog;
  j["shipped"] = s.shipped;
  j["already_there"] = s.already_there;
  j["last_success"] = iso(s.last_success_unix_s);
  j["last_failure"] = s.last_failure_unix_s ? nlohmann::ordered_json(iso(s.last_failure_unix_s))
                                            : nlohmann::ordered_json(nullptr);
  j["last_failure_reason"] = s.last_failure;
  j["consecutive_failures"] = s.consecutive_failures;
  j["updated"] = iso(now_s());
  return j.dump() + "\n";
}

std::string status_line(const std::string& status_path) {
  std::ifstream f(status_path);
  if (!f) return {};
  std::stringstream ss;
  ss << f.rdbuf();
  const auto j = nlohmann::json::parse(ss.str(), nullptr, false);
  if (j.is_discarded() || j.value("schema", "") != "brakefit.sync_status/1") return {};
  std::string line =
      fmt::format("sync to the central server: {}, backlog {}, last success {}",
                  j.value("state", "?"), j.value("backlog", -1), j.value("last_success", "?"));
  if (j.value("consecutive_failures", 0) > 0)
    line += fmt::format(", {} failures in a row (last: {})", j.value("consecutive_failures", 0),
                        j.value("last_failure_reason", ""));
  return line + fmt::format(" [{}]", j.value("updated", ""));
}

int run_sync(const SyncOptions& o) {
  const std::string status_path =
      o.status_path.empty() ? default_status_path(o.store_path) : o.status_path;
  SyncStatus st;
  std::unique_ptr<Pg> pg;
  std::unique_ptr<daemon::EventStore> store;
  std::int64_t after_id = 0, min_created = 0;
  bool resumed = false;
  double backoff = 1.0;
  auto publish = [&] {
    write_atomically(status_path, status_json(st, o));
    sd_notify(0, fmt::format("STATUS={}: backlog {}, last success {}{}", st.state, st.backlog,
                             iso(st.last_success_unix_s),
                             st.consecutive_failures
                                 ? fmt::format(", {} failures: {}", st.consecutive_failures,
                                               st.last_failure)
                                 : std::string())
                     .c_str());
  };
  auto fail = [&](const std::string& why, bool credentials) {
    st.consecutive_failures++;
    st.last_failure_unix_s = now_s();
    st.last_failure = why;
    st.state = credentials ? "credentials_refused" : "retrying";
    st.next_retry_s = backoff;
    spdlog::error("sync: {} (attempt {}; next in {:.0f} s)", why, st.consecutive_failures, backoff);
    publish();
    pg.reset();
  };
  sd_notify(0, "READY=1");
  while (!(o.stop && o.stop())) {
    try {
      if (!store) {
        daemon::StoreConfig sc;
        sc.path = o.store_path;
        store = std::make_unique<daemon::EventStore>(sc, true);
      }
      if (!pg) {
        pg = std::make_unique<Pg>(o.url, o.settings);
        pg->exec("SELECT set_config('statement_timeout', $1, false)",
                 {PgParam::text(std::to_string(o.statement_timeout_ms))});
        spdlog::info("sync: connected to {} (TLS {})", pg->describe(),
                     pg->ssl_in_use() ? "on" : "off");
        if (!resumed) {
          min_created = resume_unix_s(*pg, o.ids);
          after_id = 0;
          resumed = true;
          spdlog::info(
              "sync: the central server holds this lane's events up to {}; resuming from "
              "events committed since {}",
              min_created ? iso(min_created + kResumeMarginS) : "none", iso(min_created));
        }
      }
      const auto batch = store->after(after_id, min_created, o.batch);
      if (batch.empty()) {
        st.backlog = 0;
        st.state = "idle";
        publish();
        if (o.once) return 0;
        nap(o.poll_s, o);
        continue;
      }
      const BatchOutcome b = ship_batch(*pg, o.ids, batch, *store, o.with_samples);
      after_id = b.last_row_id;
      st.shipped += static_cast<std::int64_t>(b.inserted);
      st.already_there += static_cast<std::int64_t>(b.sent - b.inserted);
      st.last_success_unix_s = now_s();
      st.consecutive_failures = 0;
      backoff = 1.0;
      st.backlog = store->count_after(after_id, min_created);
      st.state = st.backlog ? "shipping" : "idle";
      spdlog::info("sync: shipped {} events ({} new, {} already there); backlog {}", b.sent,
                   b.inserted, b.sent - b.inserted, st.backlog);
      publish();
    } catch (const PgError& e) {
      fail(e.what(), e.auth_failure());
      if (o.once) return 75;
      nap(backoff, o);
      backoff = std::min(o.max_backoff_s, backoff * 2);
    } catch (const std::exception& e) {
      // The store: not there yet, locked for a moment, or being replaced.
      store.reset();
      fail(fmt::format("store {}: {}", o.store_path, e.what()), false);
      if (o.once) return 75;
      nap(backoff, o);
      backoff = std::min(o.max_backoff_s, backoff * 2);
    }
  }
  st.state = "stopped";
  publish();
  sd_notify(0, "STOPPING=1");
  return 0;
}

}  // namespace brakefit::fleet
