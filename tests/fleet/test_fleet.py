"""The fleet path (issue 37) against real components: a PostgreSQL 15 started here (TLS on), real
brakefitd processes replaying shipped recordings into three stations' stores, real `brakefit sync`
processes shipping them, the README's fleet lines, a new month's partition, schema migrations, the
sync's units and the weekly report (test_fleet_faults.py: security and faults; fleet_harness.py:
the server and the stations).

To give the stations a day's backlog without replaying a day, each store's real events are cloned
with new uids and earlier commit times (one every ten minutes): the rows are what brakefitd wrote,
the volume is the test's."""
import json
import os
import re
import shutil
import sqlite3
import subprocess
import tempfile
import time
import uuid
import unittest

import fleet_harness as h
from fleet_harness import (CLI, HOSTILE, ROOT, Station, run_cli, replay_into, clone_rows, age_rows,
                           store_uids, central)

setUpModule = h.set_up
tearDownModule = h.tear_down


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
        got = h.SERVER.psql(f"SELECT peak_friction, slip_stiffness_n, fit_method FROM brakefit.events "
                          f"WHERE event_uid = '{uid}'").split("|")
        self.assertAlmostEqual(float(got[0]), hybrid["D"] / 3800, places=9)
        self.assertAlmostEqual(float(got[1]), hybrid["B"] * hybrid["C"] * hybrid["D"], places=3)
        self.assertEqual(got[2], "hybrid")
        # The raw samples arrive byte for byte.
        db = sqlite3.connect(self.north.store)
        blob, count = db.execute("SELECT s.data, s.count FROM samples s JOIN events e ON "
                                 "e.id = s.event_id WHERE e.uid = ?", (uid,)).fetchone()
        db.close()
        self.assertEqual(h.SERVER.psql(f"SELECT encode(samples, 'hex') || '|' || samples_count FROM "
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
        d = tempfile.mkdtemp(dir=h.TMP)
        os.makedirs(os.path.join(d, "out", "daemon"))
        replay_into(os.path.join(d, "out", "daemon", "events.db"), ["roller_2p2bar_fast.log"])
        shutil.copy(h.SERVER.ca, os.path.join(d, "fleet-ca.crt"))
        # The same password the other tests' north station uses (add-station sets it again).
        shutil.copy(os.path.join(h.TMP, "station_north.pw"), os.path.join(d, "station_north.pw"))
        # A URL without a host or port takes libpq's PGHOST and PGPORT: the test's server.
        env = dict(os.environ, PGHOST=h.SERVER.sock, PGPORT=str(h.SERVER.port),
                   PATH=os.pathsep.join([os.path.dirname(CLI), os.environ["PATH"]]))
        env.pop("BRAKEFIT_FLEET_PASSWORD", None)
        for cmd in lines:
            r = subprocess.run(["bash", "-c", cmd], cwd=d, env=env, capture_output=True,
                               text=True, timeout=120)
            self.assertEqual(r.returncode, 0, f"{cmd}\n{r.stderr[-2000:]}")
        self.assertTrue(os.path.exists(os.path.join(d, "out", "fleet", "index.html")))


class NewMonth(unittest.TestCase):
    def test_stations_opening_a_month_at_the_same_moment_all_ship(self):
        template = os.path.join(h.TMP, "month.db")
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
            ["runuser", "-u", "postgres", "--", "psql", "-X", "-q", "-h", h.SERVER.sock, "-p",
             str(h.SERVER.port), "-d", "brakefit", "-c",
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


class Migrations(unittest.TestCase):
    def test_init_upgrades_a_version_1_schema_with_its_rows_and_a_second_init_does_nothing(self):
        # A database of its own, brought to version 1 as it shipped (the result column jsonb, the
        # second migration not applied) with a row in it: `fleet init` upgrades it in place.
        h.SERVER.psql("CREATE DATABASE brakefit_migrate", db="postgres")
        url = h.SERVER.admin_url("brakefit_migrate")
        r = run_cli("fleet", "init", url)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("to 2", r.stdout)
        h.SERVER.psql("ALTER TABLE brakefit.events ALTER COLUMN result TYPE jsonb USING result::jsonb;"
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
        self.assertEqual(h.SERVER.psql("SELECT format_type(atttypid, atttypmod) FROM pg_attribute "
                                     "WHERE attrelid = 'brakefit.events'::regclass AND "
                                     "attname = 'result'", db="brakefit_migrate"), "json")
        self.assertEqual(h.SERVER.psql("SELECT result->>'points' FROM brakefit.events "
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
        path = os.path.join(h.TMP, "brakefit-sync.service")
        with open(path, "w") as f:
            f.write(unit.replace("/usr/bin/brakefit", CLI))
        out = subprocess.run(["systemd-analyze", "verify", "--man=no", path], capture_output=True,
                             text=True, cwd=h.TMP)
        self.assertEqual(out.returncode, 0, out.stdout + out.stderr)
        out = subprocess.run(["systemd-analyze", "security", "--offline=yes", path],
                             capture_output=True, text=True, cwd=h.TMP)
        m = re.search(r"Overall exposure level for brakefit-sync.service: ([\d.]+)", out.stdout)
        self.assertIsNotNone(m, out.stdout + out.stderr)
        self.assertLessEqual(float(m.group(1)), 2.0)
        # Network out to the central server only; the password a credential, not an argument.
        for key in ("IPAddressDeny=any", "LoadCredential=fleet-password:",
                    "--password-file ${CREDENTIALS_DIRECTORY}/fleet-password", "User=brakefitd",
                    "StateDirectory=brakefit"):
            self.assertIn(key, unit)


class WeeklyReport(unittest.TestCase):
    """The fleet's weekly report: counts, a lane reading high, and station names shown as text."""

    def test_the_report_counts_every_event_and_names_the_lane_that_reads_high(self):
        # A fleet of its own (a second database: the other tests' lanes test other vehicles):
        # three lanes with eight weeks of the same vehicles; the third reads 25 % high for three.
        h.SERVER.psql("CREATE DATABASE brakefit_report", db="postgres")
        r = run_cli("fleet", "init", h.SERVER.admin_url("brakefit_report"))
        self.assertEqual(r.returncode, 0, r.stderr)
        r = run_cli("fleet", "add-station", h.SERVER.admin_url("brakefit_report"), "--station",
                    "north", "--role", "station_north", "--station-password-file",
                    os.path.join(h.TMP, "station_north.pw"))
        self.assertEqual(r.returncode, 0, r.stderr)
        lanes = []
        for i, factor in enumerate((1.0, 1.0, 1.0)):
            st = Station("north", lane=f"r{i}")
            st.url = h.SERVER.station_url("station_north", db="brakefit_report")
            replay_into(st.store, ["roller_2p2bar_slow.log"])
            age_rows(st.store, 12 * 7 * 86400)
            # Six events a day: eight weeks in line, then three weeks (the third lane high).
            clone_rows(st.store, 8 * 7 * 6, newest_age_s=3 * 7 * 86400, step_s=4 * 3600)
            clone_rows(st.store, 3 * 7 * 6, friction_factor=1.25 if i == 2 else 1.0,
                       step_s=4 * 3600)
            r = st.once(extra=("--batch", "500"))
            self.assertEqual(r.returncode, 0, r.stderr)
            lanes.append(st)
        out = os.path.join(h.TMP, "report")
        r = run_cli("fleet", "report", h.SERVER.admin_url("brakefit_report"), "--json", "--html", out,
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
        hostile = Station(HOSTILE)  # its name is markup and SQL: the report shows it as text
        replay_into(hostile.store, ["roller_1p0bar_medium.log"])
        r = hostile.once()
        self.assertEqual(r.returncode, 0, r.stderr)
        r = run_cli("fleet", "report", h.SERVER.admin_url(), "--html", os.path.join(h.TMP, "r2"))
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(os.path.join(h.TMP, "r2", "index.html")) as f:
            self.assertIn("St. Mary&apos;s&apos;); DROP TABLE", f.read())  # text, not markup
        with open(os.path.join(out, "friction.svg")) as f:
            self.assertIn("peak friction [-]", f.read())


if __name__ == "__main__":
    unittest.main()
