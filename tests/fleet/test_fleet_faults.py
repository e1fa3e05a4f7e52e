"""The fleet path under attack and faults, against a PostgreSQL started here: row-level security
between stations (a hostile station name included), and a sync running as a service while the
server is stopped, killed -9, restarted on a new port and slowed. Every fault ends with the same
check: what the station stored is what the server holds, each event once."""
import json
import os
import re
import subprocess
import time
import unittest

import fleet_harness as h
from fleet_harness import (HOSTILE, STATIONS, Station, run_cli, replay_into, clone_rows,
                           store_uids, central, write)
import pgserver

setUpModule = h.set_up
tearDownModule = h.tear_down


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
        with open(os.path.join(h.TMP, f"{role}.pw")) as f:
            pw = f.read().strip()
        env = dict(os.environ, PGPASSWORD=pw, PGSSLMODE=sslmode, PGSSLROOTCERT=h.SERVER.ca)
        return subprocess.run(["psql", "-X", "-A", "-t", "-h", "localhost", "-p", str(h.SERVER.port),
                               "-U", role, "-d", "brakefit", "-c", sql], capture_output=True,
                              text=True, env=env, timeout=30)

    def test_hostile_station_text_is_stored_as_text(self):
        self.assertEqual(central(HOSTILE), "1")
        self.assertEqual(h.SERVER.psql("SELECT count(*) FROM brakefit.stations"), str(len(STATIONS)))

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
        r = self.south.once(url=h.SERVER.station_url("station_south", ca=h.SERVER.other_ca))
        self.assertEqual(r.returncode, 75)
        self.assertIn("certificate verify failed", r.stderr)
        # The name on the certificate is checked too (verify-full): 127.0.0.1 is not "localhost".
        r = self.south.once(url=h.SERVER.station_url("station_south", host="127.0.0.1"))
        self.assertEqual(r.returncode, 75)
        self.assertIn("does not match host name", r.stderr)

    def test_a_refused_password_is_said_and_never_printed(self):
        bad = write("bad.pw", "not-the-password\n")
        r = run_cli("sync", "--once", "--store", self.south.store, "--url",
                    h.SERVER.station_url("station_south"), "--station", "south", "--lane", "1",
                    "--password-file", bad, "--status", os.path.join(h.TMP, "bad.json"))
        self.assertEqual(r.returncode, 75)
        self.assertIn("password authentication failed", r.stderr)
        self.assertNotIn("not-the-password", r.stderr)
        with open(os.path.join(h.TMP, "bad.json")) as f:
            self.assertEqual(json.load(f)["state"], "credentials_refused")

    def test_a_password_in_the_url_is_refused(self):
        r = run_cli("sync", "--once", "--store", self.south.store, "--url",
                    f"postgresql://station_south:secret@localhost:{h.SERVER.port}/brakefit",
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
        if not os.path.exists(os.path.join(h.SERVER.data, "postmaster.pid")):
            h.SERVER.start()

    def test_server_down_then_back_drains_the_backlog_with_backoff(self):
        self.s.start()
        self.s.wait_drained()
        h.SERVER.stop()
        clone_rows(self.s.store, 30)  # station work while the server is away
        time.sleep(4)
        st = self.s.status()
        self.assertEqual(st["state"], "retrying")
        self.assertGreaterEqual(st["consecutive_failures"], 2)
        # Backoff, not a busy loop: a handful of attempts in 4 s with the backoff capped at 1 s.
        self.assertLessEqual(st["consecutive_failures"], 8)
        h.SERVER.start()
        self.s.wait_drained()
        self.assertEqual(self.s.stop(), 0)
        self.s.assert_exactly_once(self)

    def test_kill_9_mid_batch_loses_and_duplicates_nothing(self):
        clone_rows(self.s.store, 3000)
        # 50 ms a statement: the 150 batches take long enough to be killed in the middle of.
        h.SERVER.psql("CREATE FUNCTION brakefit.slow() RETURNS trigger LANGUAGE plpgsql AS $$ "
                    "BEGIN PERFORM pg_sleep(0.05); RETURN NULL; END $$; "
                    "CREATE TRIGGER slow BEFORE INSERT ON brakefit.events "
                    "FOR EACH STATEMENT EXECUTE FUNCTION brakefit.slow()")
        self.s.start(extra=("--batch", "20"))
        end = time.time() + 30
        while int(central("south", lane="2")) < 1000 and time.time() < end:
            time.sleep(0.1)
        before = int(central("south", lane="2"))
        h.SERVER.kill9()
        h.SERVER.start()
        h.SERVER.psql("DROP TRIGGER slow ON brakefit.events; DROP FUNCTION brakefit.slow()")
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
        h.SERVER.psql("CREATE FUNCTION brakefit.slow() RETURNS trigger LANGUAGE plpgsql AS $$ "
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
            h.SERVER.psql("DROP TRIGGER slow ON brakefit.events; DROP FUNCTION brakefit.slow()")
        self.s.assert_exactly_once(self)

    def test_a_server_restarted_on_a_new_address_is_resumed_from_where_it_stood(self):
        self.s.once()
        old = h.SERVER.port
        h.SERVER.stop()
        while h.SERVER.port == old:
            h.SERVER.port = pgserver.free_port()
        conf = os.path.join(h.SERVER.data, "postgresql.conf")
        with open(conf, "a") as f:
            f.write(f"port = {h.SERVER.port}\n")
        h.SERVER.start()
        clone_rows(self.s.store, 4)
        r = self.s.once()  # the station's configuration names the new address
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertNotEqual(old, h.SERVER.port)
        self.assertEqual(self.s.status()["shipped"], 4)
        self.s.assert_exactly_once(self)
