// brakefit sync: ships a station's stored events to the central PostgreSQL (fleet/sync.hpp).
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <csignal>

#include "cli/commands.hpp"
#include "cli/fleet_connect.hpp"
#include "cli/io.hpp"
#include "fleet/sync.hpp"

namespace brakefit::cli {

namespace {

volatile std::sig_atomic_t g_stop = 0;
extern "C" void on_stop(int) {
  g_stop = 1;
}

}  // namespace

void add_sync_command(CLI::App& app) {
  auto o = std::make_shared<fleet::SyncOptions>();
  auto password_file = std::make_shared<std::string>();
  o->store_path = "/var/lib/brakefit/events.db";
  auto* cmd = app.add_subcommand(
      "sync", "Ship the station's stored events to the central PostgreSQL (runs until stopped)");
  cmd->add_option("--store", o->store_path, "brakefitd's event store")->capture_default_str();
  cmd->add_option("--url", o->url,
                  "the central server, e.g. postgresql://station7@fleet.example/brakefit?"
                  "sslrootcert=/etc/brakefit/fleet-ca.crt (no password: TLS verify-full)")
      ->required();
  cmd->add_option("--station", o->ids.station, "this station's id")->required();
  cmd->add_option("--lane", o->ids.lane, "this lane's id")->required();
  cmd->add_option("--password-file", *password_file,
                  "the station role's password (else $BRAKEFIT_FLEET_PASSWORD)");
  cmd->add_option("--batch", o->batch, "events per batch (one transaction)")
      ->check(CLI::Range(1, 2000))
      ->capture_default_str();
  cmd->add_flag("--samples", o->with_samples, "ship the raw samples too");
  cmd->add_flag("--once", o->once,
                "ship the backlog and exit (0), or exit 75 when the server cannot take it");
  cmd->add_option("--status", o->status_path, "status file (default: STORE.sync.json)");
  cmd->add_option("--max-backoff-s", o->max_backoff_s, "longest wait between retries")
      ->capture_default_str();
  cmd->add_option("--statement-timeout-ms", o->statement_timeout_ms,
                  "a batch's longest time on the server")
      ->capture_default_str();
  cmd->callback([o, password_file] {
    o->settings = fleet_settings(o->url, *password_file, "brakefit-sync/" + o->ids.station);
    struct sigaction sa {};
    sa.sa_handler = on_stop;
    sigaction(SIGTERM, &sa, nullptr);
    sigaction(SIGINT, &sa, nullptr);
    o->stop = [] { return g_stop != 0; };
    const int rc = fleet::run_sync(*o);
    if (rc != 0)
      throw ExitError(rc, "sync: stopped with the backlog not shipped (the errors above say why)");
  });
}

}  // namespace brakefit::cli
