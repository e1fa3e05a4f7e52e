"""The fleet path (issue 37) against real components: a PostgreSQL 15 started here (TLS on), real
brakefitd processes replaying shipped recordings into three stations' stores, real `brakefit sync`
processes, and faults done to the real server (stop, kill -9, restart on a new port, a slow
statement, a refused password). Every fault ends with the same check: what the stations stored is
what the server holds, each event once.

To give the stations a day's backlog without replaying a day, each store's real events are cloned
with new uids and earlier commit times (one every ten minutes): the rows are what brakefitd wrote,
the volume is the test's."""
import json
import os
import re
import shutil
import signal
import sqlite3
import subprocess
import tempfile
import time
import unittest
import uuid

import pgserver

CLI = os.environ["BRAKEFIT_BIN"]
DAEMON = os.environ["BRAKEFITD_BIN"]
ROOT = os.environ["BRAKEFIT_ROOT"]
REC = os.path.join(ROOT, "data", "recorded")
MODEL = os.path.join(ROOT, "data", "models", "default.json")

HOSTILE = "St. Mary's'); DROP TABLE brakefit.events; --"
STATIONS = {"north": "station_north", "south": "station_south", HOSTILE: "station_hostile"}
SERVER = None
TMP = None


def setUpModule():
    global SERVER, TMP
    pgserver.skip_unless_available()
    SERVER = pgserver.PgServer()
    TMP = tempfile.mkdtemp(prefix="brakefit-fleet-")
    r = run_cli("fleet", "init", SERVER.admin_url())
    assert r.returncode == 0, r.stderr
    for station, role in STATIONS.items():
        pw = write(f"{role}.pw", f"pw-{role}-{uuid.uuid4().hex}\n")
        r = run_cli("fleet", "add-station", SERVER.admin_url(), "--station", station, "--role", role,
                    "--station-password-file", pw)
        assert r.returncode == 0, r.stderr


def tearDownModule():
    if SERVER:
        SERVER.close()
    if TMP:
        shutil.rmtree(TMP, ignore_errors=True)


def write(name, text):
    path = os.path.join(TMP, name)
    with open(path, "w") as f:
        f.write(text)
    os.chmod(path, 0o600)
    return path


def run_cli(*args, env=None, timeout=120):
    e = dict(os.environ)
    e.pop("BRAKEFIT_FLEET_PASSWORD", None)
    e.update(env or {})
    return subprocess.run([CLI, *args], capture_output=True, text=True, timeout=timeout, env=e)


def replay_into(store, recordings):
    """brakefitd replays each recording into the store (as a station's lane does), then exits."""
    d = tempfile.mkdtemp(dir=TMP)
    logs = ""
    for rec in recordings:
        with open(os.path.join(REC, rec[:-4] + ".bench.toml")) as f:
            bench = f.read()
        cfg = os.path.join(d, "brakefitd.toml")
        with open(cfg, "w") as f:
            f.write(f'[daemon]\nmodel = "{MODEL}"\n[source]\nkind = "replay"\n'
                    f'file = "{os.path.join(REC, rec)}"\nspeed = 0\nexit_at_end = true\n{bench}\n'
                    f'[modbus_tcp]\naddress = "127.0.0.1"\nport = {pgserver.free_port()}\n'
                    f'[store]\npath = "{store}"\nmin_free_mb = 0\n')
        r = subprocess.run([DAEMON, "--config", cfg], capture_output=True, text=True, timeout=120)
        assert r.returncode == 0, r.stderr[-2000:]
        logs += r.stderr
    return logs


def clone_rows(store, n, *, friction_factor=1.0, newest_age_s=0, step_s=600):
    """n more events in the store: its real rows again with new uids, committed one every step_s
    up to now - newest_age_s (and after the store's newest: commit times only grow).
    friction_factor scales the fits' D (a tester reading high)."""
    db = sqlite3.connect(store)
    rows = db.execute("SELECT created_unix_s, source, vehicle_id, pipeline_event_id, bench, "
                      "t_start_ns, t_end_ns, end_reason, flags, points, model_hash, samples_stored, "
                      "calibration_toml, result_json FROM events WHERE uid IS NOT NULL "
                      "ORDER BY id LIMIT 4").fetchall()
    end = int(time.time()) - newest_age_s
    newest = db.execute("SELECT max(created_unix_s) FROM events").fetchone()[0]
    start = max(end - step_s * n, newest + 1)
    for i in range(n):
        r = list(rows[i % len(rows)])
        r[0] = start + (end - start) * (i + 1) // n
        r[11] = 0  # the clone has no samples row
        doc = json.loads(r[13])
        for res in doc.get("results", []):
            if isinstance(res.get("D"), (int, float)):
                res["D"] *= friction_factor
        r[13] = json.dumps(doc, separators=(",", ":"))  # as brakefitd writes it
        db.execute("INSERT INTO events (created_unix_s, source, vehicle_id, pipeline_event_id, "
                   "bench, t_start_ns, t_end_ns, end_reason, flags, points, model_hash, "
                   "samples_stored, calibration_toml, result_json, uid) VALUES "
                   "(?,?,?,?,?,?,?,?,?,?,?,?,?,?,?)", r + [uuid.uuid4().hex])
    db.commit()
    db.close()


def age_rows(store, seconds):
    """The store's events as if tested `seconds` earlier (before the clones that follow them)."""
    db = sqlite3.connect(store)
    db.execute("UPDATE events SET created_unix_s = created_unix_s - ?", (seconds,))
    db.commit()
    db.close()


def store_uids(store):
    db = sqlite3.connect(store)
    uids = {u for (u,) in db.execute("SELECT uid FROM events")}
    db.close()
    return uids


def central(station, sql_what="count(*)", lane="1"):
    q = station.replace("'", "''")
    return SERVER.psql(f"SELECT {sql_what} FROM brakefit.events WHERE station_id = '{q}' "
                       f"AND lane_id = '{lane}'")


def central_uids(station, lane):
    q = station.replace("'", "''")
    out = SERVER.psql(f"SELECT event_uid FROM brakefit.events WHERE station_id = '{q}' "
                      f"AND lane_id = '{lane}'")
    return out.splitlines() if out else []


class Station:
    def __init__(self, station, lane="1"):
        self.station, self.lane, self.role = station, lane, STATIONS[station]
        self.dir = tempfile.mkdtemp(dir=TMP)
        self.store = os.path.join(self.dir, "events.db")
        self.pw = os.path.join(TMP, f"{self.role}.pw")
        self.proc = None

    def args(self, url=None, extra=()):
        url = url or getattr(self, "url", None)
        return ["sync", "--store", self.store, "--url", url or SERVER.station_url(self.role),
                "--station", self.station, "--lane", self.lane, "--password-file", self.pw,
                "--max-backoff-s", "1", *extra]

    def once(self, url=None, extra=()):
        return run_cli(*self.args(url, ("--once",) + tuple(extra)))

    def start(self, url=None, extra=()):
        self.log = open(os.path.join(self.dir, "sync.log"), "a")
        self.proc = subprocess.Popen([CLI, *self.args(url, extra)], stdout=self.log,
                                     stderr=self.log)

    def stop(self):
        self.proc.send_signal(signal.SIGTERM)
        rc = self.proc.wait(timeout=20)
        self.log.close()
        return rc

    def status(self):
        with open(self.store + ".sync.json") as f:
            return json.load(f)

    def wait_drained(self, timeout=60):
        want = store_uids(self.store)
        end = time.time() + timeout
        while time.time() < end:
            if set(central_uids(self.station, self.lane)) >= want:
                return
            time.sleep(0.3)
        raise AssertionError(f"backlog not drained: {len(want)} stored, "
                             f"{central(self.station, lane=self.lane)} central; {self.read_log()[-2000:]}")

    def read_log(self):
        with open(os.path.join(self.dir, "sync.log")) as f:
            return f.read()

    def assert_exactly_once(self, test):
        uids = central_uids(self.station, self.lane)
        test.assertEqual(len(uids), len(set(uids)), "an event is central twice")
        test.assertEqual(set(uids), store_uids(self.store))


class Shipping(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.north = Station("north", lane="s1")  # lane 1 is the README's
        replay_into(cls.north.store, ["roller_2p2bar_fast.log", "ground_2p2bar_150barps.log"])
        age_rows(cls.north.store, 3 * 86400)
        clone_rows(cls.north.store, 120, newest_age_s=7200)

    def test_1_every_stored_event_reaches_the_server_once_and_a_rerun_adds_nothing(self):
        r = self.north.once(extra=("--batch", "50", "--samples"))
        self.assertEqual(r.returncode, 0, r.stderr)
        self.north.assert_exactly_once(self)
        st = self.north.status()
        self.assertEqual(st["schema"], "brakefit.sync_status/1")
        self.assertEqual((st["state"], st["backlog"], st["shipped"]), ("idle", 0, 122))
        # The real events carry their raw samples and the figures the report keys on.
        self.assertEqual(central("north", "count(samples)", lane="s1"), "2")
        self.assertEqual(central("north", "count(peak_friction)", lane="s1"), "122")
        # The report's figures are the hybrid fit's D / wheel load and B C D, as stored.
        db = sqlite3.connect(self.north.store)
        uid, doc = db.execute("SELECT uid, result_json FROM events ORDER BY id LIMIT 1").fetchone()
        db.close()
        hybrid = next(r for r in json.loads(doc)["results"] if r["method"] == "hybrid")
        got = SERVER.psql(f"SELECT peak_friction, slip_stiffness_n, fit_method FROM brakefit.events "
                          f"WHERE event_uid = '{uid}'").split("|")
        self.assertAlmostEqual(float(got[0]), hybrid["D"] / 3800, places=9)
        self.assertAlmostEqual(float(got[1]), hybrid["B"] * hybrid["C"] * hybrid["D"], places=3)
        self.assertEqual(got[2], "hybrid")
        # The raw samples arrive byte for byte.
        db = sqlite3.connect(self.north.store)
        blob, count = db.execute("SELECT s.data, s.count FROM samples s JOIN events e ON "
                                 "e.id = s.event_id WHERE e.uid = ?", (uid,)).fetchone()
        db.close()
        self.assertEqual(SERVER.psql(f"SELECT encode(samples, 'hex') || '|' || samples_count FROM "
                                     f"brakefit.events WHERE event_uid = '{uid}'"),
                         f"{blob.hex()}|{count}")
        r = self.north.once()
        self.assertEqual(r.returncode, 0, r.stderr)
        self.north.assert_exactly_once(self)
        self.assertEqual(self.north.status()["shipped"], 0)
        # brakefit events list shows the sync's state in its header.
        r = run_cli("events", "--db", self.north.store, "list", "--limit", "1")
        self.assertRegex(r.stdout.splitlines()[0],
                         r"^sync to the central server: idle, backlog 0, last success 20")

    def test_2_a_wiped_station_resumes_without_resending_everything(self):
        self.north.once()
        os.remove(self.north.store + ".sync.json")
        clone_rows(self.north.store, 3)
        r = self.north.once()
        self.assertEqual(r.returncode, 0, r.stderr)
        st = self.north.status()
        self.assertEqual(st["shipped"], 3)
        # Only the last hour is sent again (the resume margin), not the day.
        self.assertLessEqual(st["already_there"], 8)
        self.north.assert_exactly_once(self)

    def test_4_brakefit_sync_the_services_lean_binary_ships_as_brakefit_sync_does(self):
        # brakefit-sync ARGS is brakefit sync ARGS, without Ceres, BLAS or the simulators.
        sync_bin = CLI + "-sync"
        libs = subprocess.run(["ldd", sync_bin], capture_output=True, text=True).stdout
        for lib in ("libceres", "blas", "libgfortran", "libmodbus"):
            self.assertNotIn(lib, libs)
        clone_rows(self.north.store, 4)
        r = subprocess.run([sync_bin, *self.north.args(extra=("--once",))[1:]],
                           capture_output=True, text=True, timeout=120)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual(self.north.status()["shipped"], 4)
        self.north.assert_exactly_once(self)
        # Its errors are brakefit's: a usage error is 64 and names the program.
        r = subprocess.run([sync_bin, "--store", self.north.store], capture_output=True,
                           text=True, timeout=30)
        self.assertEqual(r.returncode, 64, r.stderr)
        self.assertIn("--url is required", r.stderr)

    def test_3_a_store_rebuilt_with_new_row_ids_duplicates_nothing(self):
        self.north.once()
        rebuilt = os.path.join(self.north.dir, "rebuilt.db")
        db = sqlite3.connect(self.north.store)
        db.execute(f"VACUUM INTO '{rebuilt}'")
        db.close()
        db = sqlite3.connect(rebuilt)
        # New row ids for every event: the uid, not the row id, is the identity.
        db.execute("UPDATE events SET id = id + 100000")
        db.commit()
        db.close()
        os.replace(rebuilt, self.north.store)
        before = int(central("north", lane="s1"))
        r = self.north.once()
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual(int(central("north", lane="s1")), before)
        self.north.assert_exactly_once(self)


class ReadmeFleetLines(unittest.TestCase):
    def test_the_readmes_central_server_commands_run_as_written(self):
        with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as f:
            lines = [ln[4:] for ln in f.read().splitlines()
                     if re.match(r"    brakefit (fleet|sync) ", ln)]
        self.assertEqual(len(lines), 4, lines)
        d = tempfile.mkdtemp(dir=TMP)
        os.makedirs(os.path.join(d, "out", "daemon"))
        replay_into(os.path.join(d, "out", "daemon", "events.db"), ["roller_2p2bar_fast.log"])
        shutil.copy(SERVER.ca, os.path.join(d, "fleet-ca.crt"))
        # The same password the other tests' north station uses (add-station sets it again).
        shutil.copy(os.path.join(TMP, "station_north.pw"), os.path.join(d, "station_north.pw"))
        # A URL without a host or port takes libpq's PGHOST and PGPORT: the test's server.
        env = dict(os.environ, PGHOST=SERVER.sock, PGPORT=str(SERVER.port),
                   PATH=os.pathsep.join([os.path.dirname(CLI), os.environ["PATH"]]))
        env.pop("BRAKEFIT_FLEET_PASSWORD", None)
        for cmd in lines:
            r = subprocess.run(["bash", "-c", cmd], cwd=d, env=env, capture_output=True,
                               text=True, timeout=120)
            self.assertEqual(r.returncode, 0, f"{cmd}\n{r.stderr[-2000:]}")
        self.assertTrue(os.path.exists(os.path.join(d, "out", "fleet", "index.html")))


class NewMonth(unittest.TestCase):
    def test_stations_opening_a_month_at_the_same_moment_all_ship(self):
        template = os.path.join(TMP, "month.db")
        replay_into(template, ["roller_1p0bar_fast.log"])
        age_rows(template, 400 * 86400)  # a month no partition exists for yet
        stations = []
        for i in range(6):
            st = Station("south", lane=f"m{i}")
            shutil.copy(template, st.store)
            db = sqlite3.connect(st.store)
            db.execute("UPDATE events SET uid = ?", (uuid.uuid4().hex,))
            db.commit()
            db.close()
            stations.append(st)
        # The month's creator is held back while all six arrive: they all find no partition, then
        # meet at its creation.
        holder = subprocess.Popen(
            ["runuser", "-u", "postgres", "--", "psql", "-X", "-q", "-h", SERVER.sock, "-p",
             str(SERVER.port), "-d", "brakefit", "-c",
             "SELECT pg_advisory_lock(hashtext('brakefit.ensure_month')), pg_sleep(3)"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(0.5)
        procs = [subprocess.Popen([CLI, *st.args(extra=("--once",))], stderr=subprocess.PIPE,
                                  text=True) for st in stations]
        holder.wait(timeout=30)
        for p in procs:
            _, err = p.communicate(timeout=60)
            self.assertEqual(p.returncode, 0, err)
        for st in stations:
            st.assert_exactly_once(self)


class Security(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.south = Station("south")
        replay_into(cls.south.store, ["roller_1p0bar_fast.log"])
        clone_rows(cls.south.store, 5)
        cls.hostile = Station(HOSTILE)
        replay_into(cls.hostile.store, ["roller_1p0bar_medium.log"])
        for s in (cls.south, cls.hostile):
            r = s.once()
            assert r.returncode == 0, r.stderr

    def psql_as(self, role, sql, sslmode="verify-full"):
        with open(os.path.join(TMP, f"{role}.pw")) as f:
            pw = f.read().strip()
        env = dict(os.environ, PGPASSWORD=pw, PGSSLMODE=sslmode, PGSSLROOTCERT=SERVER.ca)
        return subprocess.run(["psql", "-X", "-A", "-t", "-h", "localhost", "-p", str(SERVER.port),
                               "-U", role, "-d", "brakefit", "-c", sql], capture_output=True,
                              text=True, env=env, timeout=30)

    def test_hostile_station_text_is_stored_as_text(self):
        self.assertEqual(central(HOSTILE), "1")
        self.assertEqual(SERVER.psql("SELECT count(*) FROM brakefit.stations"), str(len(STATIONS)))

    def test_a_station_reads_and_inserts_only_its_own_rows_and_never_updates_or_deletes(self):
        r = self.psql_as("station_south", "SELECT DISTINCT station_id FROM brakefit.events")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual(r.stdout.split(), ["south"])
        r = self.psql_as("station_south",
                         "INSERT INTO brakefit.events (station_id, lane_id, event_uid, created_at, "
                         "store_row_id, source, vehicle_id, bench, end_reason, flags, points, "
                         "model_hash, calibration_toml, result) VALUES ('north', '1', 'forged', "
                         "now(), 1, '', '', 'roller', 'x', '', 1, '', '', '{}')")
        self.assertNotEqual(r.returncode, 0)
        self.assertIn("row-level security", r.stderr)
        for sql in ("UPDATE brakefit.events SET flags = 'x'", "DELETE FROM brakefit.events",
                    "CREATE TABLE brakefit.mine (x int)", "SELECT * FROM brakefit.stations"):
            r = self.psql_as("station_south", sql)
            self.assertNotEqual(r.returncode, 0, sql)
            self.assertIn("permission denied", r.stderr, sql)

    def test_tls_is_required_and_the_servers_certificate_checked(self):
        r = self.psql_as("station_south", "SELECT 1", sslmode="disable")
        self.assertNotEqual(r.returncode, 0)
        self.assertIn("no encryption", r.stderr)
        r = self.south.once(url=SERVER.station_url("station_south", ca=SERVER.other_ca))
        self.assertEqual(r.returncode, 75)
        self.assertIn("certificate verify failed", r.stderr)
        # The name on the certificate is checked too (verify-full): 127.0.0.1 is not "localhost".
        r = self.south.once(url=SERVER.station_url("station_south", host="127.0.0.1"))
        self.assertEqual(r.returncode, 75)
        self.assertIn("does not match host name", r.stderr)

    def test_a_refused_password_is_said_and_never_printed(self):
        bad = write("bad.pw", "not-the-password\n")
        r = run_cli("sync", "--once", "--store", self.south.store, "--url",
                    SERVER.station_url("station_south"), "--station", "south", "--lane", "1",
                    "--password-file", bad, "--status", os.path.join(TMP, "bad.json"))
        self.assertEqual(r.returncode, 75)
        self.assertIn("password authentication failed", r.stderr)
        self.assertNotIn("not-the-password", r.stderr)
        with open(os.path.join(TMP, "bad.json")) as f:
            self.assertEqual(json.load(f)["state"], "credentials_refused")

    def test_a_password_in_the_url_is_refused(self):
        r = run_cli("sync", "--once", "--store", self.south.store, "--url",
                    f"postgresql://station_south:secret@localhost:{SERVER.port}/brakefit",
                    "--station", "south", "--lane", "1")
        self.assertEqual(r.returncode, 64)
        self.assertIn("carries a password", r.stderr)
        self.assertNotIn("secret", r.stderr)


class Faults(unittest.TestCase):
    """A sync running as a service while the server is stopped, killed and slowed."""

    @classmethod
    def setUpClass(cls):
        cls.s = Station("south", lane="2")
        replay_into(cls.s.store, ["roller_2p2bar_medium.log"])
        clone_rows(cls.s.store, 20, newest_age_s=7200)

    def tearDown(self):
        if self.s.proc and self.s.proc.poll() is None:
            self.s.stop()
        if not os.path.exists(os.path.join(SERVER.data, "postmaster.pid")):
            SERVER.start()

    def test_server_down_then_back_drains_the_backlog_with_backoff(self):
        self.s.start()
        self.s.wait_drained()
        SERVER.stop()
        clone_rows(self.s.store, 30)  # station work while the server is away
        time.sleep(4)
        st = self.s.status()
        self.assertEqual(st["state"], "retrying")
        self.assertGreaterEqual(st["consecutive_failures"], 2)
        # Backoff, not a busy loop: a handful of attempts in 4 s with the backoff capped at 1 s.
        self.assertLessEqual(st["consecutive_failures"], 8)
        SERVER.start()
        self.s.wait_drained()
        self.assertEqual(self.s.stop(), 0)
        self.s.assert_exactly_once(self)

    def test_kill_9_mid_batch_loses_and_duplicates_nothing(self):
        clone_rows(self.s.store, 3000)
        # 50 ms a statement: the 150 batches take long enough to be killed in the middle of.
        SERVER.psql("CREATE FUNCTION brakefit.slow() RETURNS trigger LANGUAGE plpgsql AS $$ "
                    "BEGIN PERFORM pg_sleep(0.05); RETURN NULL; END $$; "
                    "CREATE TRIGGER slow BEFORE INSERT ON brakefit.events "
                    "FOR EACH STATEMENT EXECUTE FUNCTION brakefit.slow()")
        self.s.start(extra=("--batch", "20"))
        end = time.time() + 30
        while int(central("south", lane="2")) < 1000 and time.time() < end:
            time.sleep(0.1)
        before = int(central("south", lane="2"))
        SERVER.kill9()
        SERVER.start()
        SERVER.psql("DROP TRIGGER slow ON brakefit.events; DROP FUNCTION brakefit.slow()")
        self.s.wait_drained(timeout=120)
        self.assertGreater(int(central("south", lane="2")), before)
        self.s.stop()
        self.s.assert_exactly_once(self)

    def test_brakefitd_commits_while_the_sync_reads_its_store(self):
        clone_rows(self.s.store, 2000)
        self.s.start(extra=("--batch", "10"))
        time.sleep(0.3)
        before = len(store_uids(self.s.store))
        # A real brakefitd storing an event into the store the sync is reading from.
        log = replay_into(self.s.store, ["roller_1p0bar_slow.log"])
        self.assertEqual(len(store_uids(self.s.store)), before + 1)
        # The words in what the daemon said, not in the paths it named (a temporary directory
        # once read tmpsrfcbusy).
        said = re.sub(r"/\S+", "<path>", log)
        self.assertNotIn("locked", said)
        self.assertNotIn("busy", said)
        self.s.wait_drained()
        self.assertEqual(self.s.stop(), 0)
        self.s.assert_exactly_once(self)

    def test_a_slow_server_still_takes_the_batch(self):
        SERVER.psql("CREATE FUNCTION brakefit.slow() RETURNS trigger LANGUAGE plpgsql AS $$ "
                    "BEGIN PERFORM pg_sleep(10); RETURN NULL; END $$; "
                    "CREATE TRIGGER slow BEFORE INSERT ON brakefit.events "
                    "FOR EACH STATEMENT EXECUTE FUNCTION brakefit.slow()")
        try:
            clone_rows(self.s.store, 5)
            t0 = time.time()
            r = self.s.once()
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertGreaterEqual(time.time() - t0, 10)
        finally:
            SERVER.psql("DROP TRIGGER slow ON brakefit.events; DROP FUNCTION brakefit.slow()")
        self.s.assert_exactly_once(self)

    def test_a_server_restarted_on_a_new_address_is_resumed_from_where_it_stood(self):
        self.s.once()
        old = SERVER.port
        SERVER.stop()
        while SERVER.port == old:
            SERVER.port = pgserver.free_port()
        conf = os.path.join(SERVER.data, "postgresql.conf")
        with open(conf, "a") as f:
            f.write(f"port = {SERVER.port}\n")
        SERVER.start()
        clone_rows(self.s.store, 4)
        r = self.s.once()  # the station's configuration names the new address
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertNotEqual(old, SERVER.port)
        self.assertEqual(self.s.status()["shipped"], 4)
        self.s.assert_exactly_once(self)


class Migrations(unittest.TestCase):
    def test_init_upgrades_a_version_1_schema_with_its_rows_and_a_second_init_does_nothing(self):
        # A database of its own, brought to version 1 as it shipped (the result column jsonb, the
        # second migration not applied) with a row in it: `fleet init` upgrades it in place.
        SERVER.psql("CREATE DATABASE brakefit_migrate", db="postgres")
        url = SERVER.admin_url("brakefit_migrate")
        r = run_cli("fleet", "init", url)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("to 2", r.stdout)
        SERVER.psql("ALTER TABLE brakefit.events ALTER COLUMN result TYPE jsonb USING result::jsonb;"
                    "DELETE FROM brakefit.schema_version WHERE version = 2;"
                    "SELECT brakefit.ensure_month(now());"
                    "INSERT INTO brakefit.events (station_id, lane_id, event_uid, created_at, "
                    "store_row_id, source, vehicle_id, bench, end_reason, flags, points, model_hash, "
                    "calibration_toml, result) VALUES ('north', '1', 'u1', now(), 1, '', '', "
                    "'roller', 'release', '', 900, 'h', '', '{\"schema\": \"brakefit.event/1\", "
                    "\"points\": 900}')", db="brakefit_migrate")
        r = run_cli("fleet", "init", url)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("from version 1 to 2", r.stdout)
        self.assertEqual(SERVER.psql("SELECT format_type(atttypid, atttypmod) FROM pg_attribute "
                                     "WHERE attrelid = 'brakefit.events'::regclass AND "
                                     "attname = 'result'", db="brakefit_migrate"), "json")
        self.assertEqual(SERVER.psql("SELECT result->>'points' FROM brakefit.events "
                                     "WHERE event_uid = 'u1'", db="brakefit_migrate"), "900")
        r = run_cli("fleet", "init", url)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("at version 2 already", r.stdout)


class SyncUnit(unittest.TestCase):
    def test_the_sync_unit_verifies_and_is_sandboxed(self):
        if not shutil.which("systemd-analyze"):
            self.skipTest("systemd-analyze is not installed")
        with open(os.path.join(ROOT, "systemd", "brakefit-sync.service")) as f:
            unit = f.read()
        path = os.path.join(TMP, "brakefit-sync.service")
        with open(path, "w") as f:
            f.write(unit.replace("/usr/bin/brakefit", CLI))
        out = subprocess.run(["systemd-analyze", "verify", "--man=no", path], capture_output=True,
                             text=True, cwd=TMP)
        self.assertEqual(out.returncode, 0, out.stdout + out.stderr)
        out = subprocess.run(["systemd-analyze", "security", "--offline=yes", path],
                             capture_output=True, text=True, cwd=TMP)
        m = re.search(r"Overall exposure level for brakefit-sync.service: ([\d.]+)", out.stdout)
        self.assertIsNotNone(m, out.stdout + out.stderr)
        self.assertLessEqual(float(m.group(1)), 2.0)
        # Network out to the central server only; the password a credential, not an argument.
        for key in ("IPAddressDeny=any", "LoadCredential=fleet-password:",
                    "--password-file ${CREDENTIALS_DIRECTORY}/fleet-password", "User=brakefitd",
                    "StateDirectory=brakefit"):
            self.assertIn(key, unit)


class WeeklyReport(unittest.TestCase):
    """Runs last (classes run in name order): every other station has shipped by then."""

    def test_the_report_counts_every_event_and_names_the_lane_that_reads_high(self):
        # A fleet of its own (a second database: the other tests' lanes test other vehicles):
        # three lanes with eight weeks of the same vehicles; the third reads 25 % high for three.
        SERVER.psql("CREATE DATABASE brakefit_report", db="postgres")
        r = run_cli("fleet", "init", SERVER.admin_url("brakefit_report"))
        self.assertEqual(r.returncode, 0, r.stderr)
        r = run_cli("fleet", "add-station", SERVER.admin_url("brakefit_report"), "--station",
                    "north", "--role", "station_north", "--station-password-file",
                    os.path.join(TMP, "station_north.pw"))
        self.assertEqual(r.returncode, 0, r.stderr)
        lanes = []
        for i, factor in enumerate((1.0, 1.0, 1.0)):
            st = Station("north", lane=f"r{i}")
            st.url = SERVER.station_url("station_north", db="brakefit_report")
            replay_into(st.store, ["roller_2p2bar_slow.log"])
            age_rows(st.store, 12 * 7 * 86400)
            # Six events a day: eight weeks in line, then three weeks (the third lane high).
            clone_rows(st.store, 8 * 7 * 6, newest_age_s=3 * 7 * 86400, step_s=4 * 3600)
            clone_rows(st.store, 3 * 7 * 6, friction_factor=1.25 if i == 2 else 1.0,
                       step_s=4 * 3600)
            r = st.once(extra=("--batch", "500"))
            self.assertEqual(r.returncode, 0, r.stderr)
            lanes.append(st)
        out = os.path.join(TMP, "report")
        r = run_cli("fleet", "report", SERVER.admin_url("brakefit_report"), "--json", "--html", out,
                    "--weeks", "20")
        self.assertEqual(r.returncode, 0, r.stderr)
        doc = json.loads(r.stdout)
        self.assertEqual(doc["schema"], "brakefit.fleet_report/1")
        self.assertEqual(doc["events"], sum(len(store_uids(st.store)) for st in lanes))
        by = {(l["station"], l["lane"]): l for l in doc["lanes"]}
        high = by[("north", "r2")]["peak_friction"]["verdict"]
        self.assertTrue(high["departs"], high)
        self.assertEqual(high["direction"], "high")
        self.assertIsNotNone(high["since"])
        for lane in ("r0", "r1"):
            self.assertFalse(by[("north", lane)]["peak_friction"]["verdict"]["departs"])
        self.assertTrue(doc["models"][0]["model_hash"].startswith("sha256:"))
        with open(os.path.join(out, "index.html")) as f:
            html = f.read()
        self.assertIn("reads higher than the fleet since", html)
        r = run_cli("fleet", "report", SERVER.admin_url(), "--html", os.path.join(TMP, "r2"))
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(os.path.join(TMP, "r2", "index.html")) as f:
            self.assertIn("St. Mary&apos;s&apos;); DROP TABLE", f.read())  # text, not markup
        with open(os.path.join(out, "friction.svg")) as f:
            self.assertIn("peak friction [-]", f.read())


if __name__ == "__main__":
    unittest.main()
