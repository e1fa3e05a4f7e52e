// brakefit fleet init|add-station|report: the central server's schema, its station roles, and the
// fleet report (fleet/schema.hpp, fleet/report.hpp).
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <iostream>

#include "brakefit/version.hpp"
#include "cli/commands.hpp"
#include "cli/fleet_connect.hpp"
#include "cli/io.hpp"
#include "fleet/report.hpp"
#include "fleet/schema.hpp"

namespace brakefit::cli {

namespace {

std::unique_ptr<fleet::Pg> connect(const std::string& url, const std::string& password_file,
                                   const std::string& what) {
  try {
    return std::make_unique<fleet::Pg>(url, fleet_settings(url, password_file, "brakefit-" + what));
  } catch (const fleet::PgError& e) {
    throw ExitError(kExitUnavailable, e.what());
  }
}

}  // namespace

void add_fleet_command(CLI::App& app) {
  struct Opts {
    std::string url, password_file, station, role, station_password_file, html;
    bool json = false;
    double weeks = 26;
  };
  auto o = std::make_shared<Opts>();
  auto* cmd = app.add_subcommand("fleet", "The central PostgreSQL of many stations");
  cmd->require_subcommand(1);

  auto* init = cmd->add_subcommand("init", "Create or upgrade the central schema (idempotent)");
  init->add_option("url", o->url, "the central server (an administrator's role)")->required();
  init->add_option("--password-file", o->password_file,
                   "the role's password (else $BRAKEFIT_FLEET_PASSWORD)");
  init->callback([o] {
    auto pg = connect(o->url, o->password_file, "fleet-init");
    try {
      const auto r = fleet::init_schema(*pg);
      if (r.from_version == r.to_version)
        fmt::print("schema at version {} already: nothing to do\n", r.to_version);
      else
        fmt::print("schema upgraded from version {} to {}\n", r.from_version, r.to_version);
    } catch (const fleet::PgError& e) {
      throw ExitError(kExitUnavailable, fmt::format("fleet init: {}", e.what()));
    }
  });

  auto* add = cmd->add_subcommand(
      "add-station", "Create a station's login role: it inserts and reads its own rows only");
  add->add_option("url", o->url, "the central server (an administrator's role)")->required();
  add->add_option("--password-file", o->password_file, "the administrator's password file");
  add->add_option("--station", o->station, "the station's id")->required();
  add->add_option("--role", o->role, "its login role")->required();
  add->add_option("--station-password-file", o->station_password_file,
                  "the station role's password (a file: never on the command line)")
      ->required();
  add->callback([o] {
    auto pg = connect(o->url, o->password_file, "fleet-add-station");
    const std::string station_pw = read_password_file(o->station_password_file);
    try {
      fleet::add_station(*pg, o->station, o->role, station_pw);
    } catch (const fleet::PgError& e) {
      throw ExitError(kExitUnavailable, fmt::format("fleet add-station: {}", e.what()));
    }
    fmt::print("station {} ships as role {}\n", o->station, o->role);
  });

  auto* report = cmd->add_subcommand(
      "report",
      "Per station and lane: events, flags, peak friction and slip stiffness over time "
      "against the fleet, roller vs road, model hashes");
  report->add_option("url", o->url, "the central server")->required();
  report->add_option("--password-file", o->password_file, "the role's password file");
  report->add_option("--html", o->html, "write index.html and SVG charts here");
  report->add_flag("--json", o->json, "print a brakefit.fleet_report/1 JSON document");
  report->add_option("--weeks", o->weeks, "how many weeks back")->capture_default_str();
  report->callback([o] {
    auto pg = connect(o->url, o->password_file, "fleet-report");
    fleet::Report rep;
    try {
      rep = fleet::build_report(*pg, o->weeks);
    } catch (const fleet::PgError& e) {
      throw ExitError(kExitUnavailable, fmt::format("fleet report: {}", e.what()));
    }
    if (!o->html.empty()) {
      make_output_dir(o->html);
      for (const auto& [name, text] : fleet::report_files(rep))
        write_file(o->html + "/" + name, text);
      spdlog::info("fleet report written to {}/index.html", o->html);
    }
    if (o->json) {
      auto j = fleet::report_json(rep);
      std::cout << j.dump() << "\n";
    } else {
      std::cout << fleet::report_text(rep);
    }
  });
}

}  // namespace brakefit::cli
