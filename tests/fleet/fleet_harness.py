"""The fleet tests' harness: a PostgreSQL 15 started here (TLS on) with the fleet schema and three
stations' roles, brakefitd replaying shipped recordings into a station's store, its rows cloned
into a backlog, `brakefit sync` run once or as a service, and what the server holds read back.
Each test module starts its own server (set_up/tear_down as its module fixtures)."""
import json
import os
import shutil
import signal
import sqlite3
import subprocess
import tempfile
import time
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


def set_up():
    """The server, the fleet schema and the three stations' roles (a test module's setUpModule)."""
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


def tear_down():
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
