#pragma once
// The central schema (PostgreSQL): versioned migrations applied in order under an advisory lock,
// each in its own transaction, recorded in brakefit.schema_version, so `brakefit fleet init` can be
// run again at any time (creates or upgrades, never repeats a step).
//
//   brakefit.stations   station id -> the login role that ships for it
//   brakefit.events     one row per event, partitioned by month of its commit time; primary key
//                       (event_uid, created_at): a second insert of an event is a no-op
//   brakefit.ensure_month(t)  creates a month's partition (SECURITY DEFINER: stations run no DDL)
//   brakefit.my_station()     the station of the session's login role (row-level security)
//   brakefit_station    the group role of station roles: INSERT and SELECT on events, its own
//                       station's rows only; no UPDATE, no DELETE
#include <string>

#include "fleet/pg.hpp"

namespace brakefit::fleet {

inline constexpr int kSchemaVersion = 2;

struct InitOutcome {
  int from_version = 0;
  int to_version = 0;
};

/// Creates or upgrades the schema. Needs a role that may create schemas and roles.
InitOutcome init_schema(Pg& pg);

/// Creates (or updates the password and membership of) a station's login role and maps the
/// station to it. The names and the password go through format(%I, %L) on the server: hostile
/// text stays text.
void add_station(Pg& pg, const std::string& station, const std::string& role,
                 const std::string& password);

/// The schema version on the server (0: none).
int schema_version(Pg& pg);

}  // namespace brakefit::fleet
