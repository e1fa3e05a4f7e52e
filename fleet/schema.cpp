#include "fleet/schema.hpp"

#include <array>

namespace brakefit::fleet {

namespace {

// Migration k brings the schema from version k to k + 1. Never edit one that has shipped: add the
// next.
constexpr std::array<const char*, kSchemaVersion> kMigrations = {
    R"sql(
CREATE TABLE brakefit.stations (
  station_id text PRIMARY KEY,
  role_name name UNIQUE NOT NULL,
  created_at timestamptz NOT NULL DEFAULT now()
);
CREATE TABLE brakefit.events (
  station_id text NOT NULL,
  lane_id text NOT NULL,
  event_uid text NOT NULL,
  created_at timestamptz NOT NULL,
  store_row_id bigint NOT NULL,
  source text NOT NULL,
  vehicle_id text NOT NULL,
  bench text NOT NULL,
  end_reason text NOT NULL,
  flags text NOT NULL,
  points integer NOT NULL,
  model_hash text NOT NULL,
  calibration_toml text NOT NULL,
  result jsonb COMPRESSION lz4 NOT NULL,
  wheel_load_n double precision,
  peak_friction double precision,
  slip_stiffness_n double precision,
  fit_method text,
  samples bytea COMPRESSION lz4,
  samples_count integer,
  shipped_at timestamptz NOT NULL DEFAULT now(),
  PRIMARY KEY (event_uid, created_at)
) PARTITION BY RANGE (created_at);
CREATE INDEX events_lane_time ON brakefit.events (station_id, lane_id, created_at);

CREATE FUNCTION brakefit.my_station() RETURNS text
  LANGUAGE sql STABLE SECURITY DEFINER SET search_path = brakefit, pg_temp
  AS $$ SELECT station_id FROM brakefit.stations WHERE role_name = session_user $$;

CREATE FUNCTION brakefit.ensure_month(t timestamptz) RETURNS void
  LANGUAGE plpgsql SECURITY DEFINER SET search_path = brakefit, pg_temp AS $$
DECLARE
  m date := date_trunc('month', t AT TIME ZONE 'UTC')::date;
  part text := format('events_%s', to_char(m, 'YYYY_MM'));
BEGIN
  IF to_regclass(format('brakefit.%I', part)) IS NOT NULL THEN RETURN; END IF;
  -- Stations opening a month at the same moment: one creates it, the others find it made (the
  -- check above can miss a partition committed after this statement's snapshot was taken).
  PERFORM pg_advisory_xact_lock(hashtext('brakefit.ensure_month'));
  BEGIN
    EXECUTE format('CREATE TABLE IF NOT EXISTS brakefit.%I PARTITION OF brakefit.events '
                   'FOR VALUES FROM (%L) TO (%L)', part, m::timestamp AT TIME ZONE 'UTC',
                   (m + interval '1 month')::timestamp AT TIME ZONE 'UTC');
  EXCEPTION WHEN duplicate_table OR unique_violation THEN
    NULL;
  END;
END $$;

CREATE FUNCTION brakefit.add_station(station text, role text, password text) RETURNS void
  LANGUAGE plpgsql SET search_path = brakefit, pg_temp AS $$
BEGIN
  IF EXISTS (SELECT 1 FROM pg_roles WHERE rolname = role) THEN
    EXECUTE format('ALTER ROLE %I LOGIN NOSUPERUSER NOCREATEDB NOCREATEROLE NOBYPASSRLS PASSWORD %L',
                   role, password);
  ELSE
    EXECUTE format('CREATE ROLE %I LOGIN PASSWORD %L', role, password);
  END IF;
  EXECUTE format('GRANT brakefit_station TO %I', role);
  INSERT INTO brakefit.stations (station_id, role_name) VALUES (station, role)
    ON CONFLICT (station_id) DO UPDATE SET role_name = EXCLUDED.role_name;
END $$;

DO $$ BEGIN
  IF NOT EXISTS (SELECT 1 FROM pg_roles WHERE rolname = 'brakefit_station') THEN
    CREATE ROLE brakefit_station NOLOGIN;
  END IF;
END $$;
REVOKE ALL ON FUNCTION brakefit.ensure_month(timestamptz) FROM PUBLIC;
REVOKE ALL ON FUNCTION brakefit.add_station(text, text, text) FROM PUBLIC;
GRANT USAGE ON SCHEMA brakefit TO brakefit_station;
GRANT SELECT, INSERT ON brakefit.events TO brakefit_station;
GRANT EXECUTE ON FUNCTION brakefit.my_station(), brakefit.ensure_month(timestamptz)
  TO brakefit_station;
ALTER TABLE brakefit.events ENABLE ROW LEVEL SECURITY;
-- (SELECT ...): evaluated once a statement, not once a row (a batch is one statement).
CREATE POLICY station_own_rows ON brakefit.events
  USING (station_id = (SELECT brakefit.my_station()))
  WITH CHECK (station_id = (SELECT brakefit.my_station()));
)sql",
    // 1 -> 2: the result kept as the station wrote it (json keeps the text: key order and numbers
    // as written, validated on the way in). Nothing queries inside it; jsonb's conversion was
    // 12 % of the server's CPU per event taken (bench/fleet_ingest.py, 3 runs each way).
    R"sql(
ALTER TABLE brakefit.events ALTER COLUMN result TYPE json USING result::json;
)sql",
};

}  // namespace

int schema_version(Pg& pg) {
  const PgResult t = pg.exec("SELECT to_regclass('brakefit.schema_version') IS NOT NULL");
  if (t.text(0, 0) != "t") return 0;
  const PgResult r = pg.exec("SELECT COALESCE(max(version), 0) FROM brakefit.schema_version");
  return std::stoi(r.text(0, 0));
}

InitOutcome init_schema(Pg& pg) {
  // One initialiser at a time (two operators, or a timer and an operator).
  pg.exec("SELECT pg_advisory_lock(hashtext('brakefit.init_schema'))");
  InitOutcome out;
  try {
    pg.exec_script(
        "CREATE SCHEMA IF NOT EXISTS brakefit;"
        "CREATE TABLE IF NOT EXISTS brakefit.schema_version (version integer PRIMARY KEY, "
        "applied_at timestamptz NOT NULL DEFAULT now())");
    out.from_version = schema_version(pg);
    for (int v = out.from_version; v < kSchemaVersion; ++v) {
      pg.exec_script(std::string("BEGIN;") + kMigrations[static_cast<std::size_t>(v)] +
                     ";INSERT INTO brakefit.schema_version (version) VALUES (" +
                     std::to_string(v + 1) + ");COMMIT;");
    }
    out.to_version = schema_version(pg);
  } catch (...) {
    pg.exec_script("ROLLBACK");
    pg.exec("SELECT pg_advisory_unlock(hashtext('brakefit.init_schema'))");
    throw;
  }
  pg.exec("SELECT pg_advisory_unlock(hashtext('brakefit.init_schema'))");
  return out;
}

void add_station(Pg& pg, const std::string& station, const std::string& role,
                 const std::string& password) {
  pg.exec("SELECT brakefit.add_station($1, $2, $3)",
          {PgParam::text(station), PgParam::text(role), PgParam::text(password)});
}

}  // namespace brakefit::fleet
