"""brakefitd as real processes on loopback: replay end to end (published parameters equal
`brakefit replay`'s after float32 rounding, whatever the pacing; the store holds them), libmodbus
and mbpoll clients, sd_notify READY/RELOADING/WATCHDOG/STOPPING on our own NOTIFY_SOCKET, config
errors, absent sources, faults (sensor timeout mid-event, malformed requests, 100 clients,
kill -9 during an event), the systemd unit and cmake --install."""
import json
import math
import os
import re
import shutil
import signal
import socket
import sqlite3
import struct
import subprocess
import tempfile
import time
import unittest

from daemontools import (BENCH, CLI, DAEMON, METHODS, REC, ROOT, Daemon, Notify, f32,
                         replay_reference, stored)
from logtools import concat, read_log, read_text, write_log


class DaemonTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.mkdtemp(prefix="bf_daemon_")
        self.daemons = []

    def tearDown(self):
        for d in self.daemons:
            if d.proc.poll() is None:
                d.proc.kill()
                d.proc.wait()
        shutil.rmtree(self.tmp, ignore_errors=True)

    def start(self, *a, **k):
        d = Daemon(self.tmp, *a, **k)
        self.daemons.append(d)
        return d

    def three_events_log(self):
        path = os.path.join(self.tmp, "three.log")
        write_log(path, concat([read_log(os.path.join(REC, f"roller_2p2bar_{s}.log")) for s in ("fast", "medium", "slow")]))
        shutil.copy(os.path.join(REC, "roller_2p2bar_fast.bench.toml"),
                    os.path.join(self.tmp, "three.bench.toml"))
        return path

    def assert_published_equals(self, probe, ref):
        r = probe["registers"]
        self.assertTrue(probe["consistent"])
        reasons = ["other", "switch_off_slip", "wheel_lock", "release", "stopped"]
        self.assertEqual(reasons[r["event.end_reason"]], ref["end_reason"])
        # Bit 6: an lm or hybrid parameter at its bound, as the reference's JSON says.
        at_bound = any(x["at_bound"] for x in ref["results"] if x["method"] in ("lm", "hybrid"))
        self.assertEqual(r["event.flags"], 64 if at_bound else 0)
        self.assertEqual(r["event.points"], ref["points"])
        by = {x["method"]: x for x in ref["results"]}
        for m in METHODS:
            for p in "BCDE":
                self.assertEqual(r[f"event.{m}.{p}"], f32(by[m][p]), f"{m}.{p}")
            self.assertEqual(r[f"event.{m}.mape_pct"], f32(by[m]["mape_pct"]))
        h = int(ref["model_hash"].split(":")[1][:8], 16)
        self.assertEqual(r["event.model_hash"], h)

    def test_replay_publishes_what_brakefit_replay_computes_whatever_the_pacing(self):
        log = self.three_events_log()
        ref = replay_reference(log)
        self.assertEqual(len(ref), 3)
        for speed in (0.0, 4.0):
            with self.subTest(speed=speed):
                store = os.path.join(self.tmp, f"events-{speed}.db")
                d = self.start(log, speed=speed, store=store)
                p = d.wait_events(3, timeout=60)
                self.assert_published_equals(p, ref[-1])
                self.assertEqual(p["registers"]["event.id"], 3)
                self.assertEqual(p["registers"]["events_flagged"], 0)
                self.assertTrue(p["registers"]["status_flags"] & 1)
                # mbpoll (a third-party client) reads the same hybrid B, C, D, E (ABCD floats).
                out = subprocess.run(["mbpoll", "-m", "tcp", "-p", str(d.port), "-0", "-1", "-B",
                                      "-t", "3:float", "-r", "156", "-c", "4", "127.0.0.1"],
                                     capture_output=True, text=True, timeout=10)
                vals = [float(v) for v in re.findall(r"^\[\d+\]:\s+(\S+)", out.stdout, re.M)]
                hyb = next(x for x in ref[-1]["results"] if x["method"] == "hybrid")
                self.assertEqual(len(vals), 4, out.stdout + out.stderr)
                for v, k in zip(vals, "BCDE"):
                    self.assertAlmostEqual(v, hyb[k], delta=abs(hyb[k]) * 1e-5 + 1e-6)
                self.assertEqual(d.stop(), 0)
                # The store holds every event with the same results.
                st = stored(store)
                self.assertEqual([s["id"] for s in st], [1, 2, 3])
                for s, r in zip(st, ref):
                    self.assertTrue(s["samples_stored"])
                    self.assertEqual(s["event"]["results"], r["results"])
                    self.assertEqual(s["model_hash"], r["model_hash"])
                # events show / export: the stored samples replay to the same event.
                out = subprocess.run([CLI, "events", "--db", store, "show", "2"],
                                     capture_output=True, text=True, timeout=30)
                self.assertEqual(out.returncode, 0, out.stderr)
                shown = json.loads(out.stdout)
                self.assertEqual(shown["schema"], "brakefit.stored_event/1")
                self.assertEqual(shown["event"]["results"], ref[1]["results"])
                csv = os.path.join(self.tmp, f"e2-{speed}.csv")
                out = subprocess.run([CLI, "events", "--db", store, "export", "2", "--out", csv],
                                     capture_output=True, text=True, timeout=30)
                self.assertEqual(out.returncode, 0, out.stderr)
                again = replay_reference(csv)
                self.assertEqual(len(again), 1)
                self.assertEqual(again[0]["points"], ref[1]["points"])
                out = subprocess.run([CLI, "events", "--db", store, "show", "99"],
                                     capture_output=True, text=True, timeout=30)
                self.assertEqual(out.returncode, 65)
                self.assertIn("no event with id 99", out.stderr)
                # Options anywhere on the line; times in ISO 8601 (UTC).
                out = subprocess.run([CLI, "events", "list", "--db", store, "--limit", "2"],
                                     capture_output=True, text=True, timeout=30)
                self.assertEqual(out.returncode, 0, out.stderr)
                rows = out.stdout.splitlines()
                self.assertEqual(len(rows), 3, out.stdout)  # header + 2
                self.assertRegex(rows[1], r"^\s+3\s+\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ\s")
                out = subprocess.run([CLI, "events", "show", "1", "--db", store],
                                     capture_output=True, text=True, timeout=30)
                self.assertEqual(out.returncode, 0, out.stderr)
                shown = json.loads(out.stdout)
                self.assertRegex(shown["created"], r"^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ$")
                stats = json.loads(read_text(d.stats))
                self.assertEqual(stats["events"], 3)
                self.assertEqual(stats["publish_latency_us"]["n"], 3)

    def test_notify_ready_watchdog_reload_and_clean_stop(self):
        notify = Notify(os.path.join(self.tmp, "notify.sock"))
        d = self.start(os.path.join(REC, "roller_2p2bar_fast.log"),
                       env={"NOTIFY_SOCKET": notify.path, "WATCHDOG_USEC": "200000"})
        i = notify.wait_for("READY=1")
        w = notify.wait_for("WATCHDOG=1", after=i)
        notify.wait_for("WATCHDOG=1", after=w + 1)  # keeps pinging while idle after the replay
        self.assertTrue(any(m.startswith("STATUS=") for m in notify.messages))
        d.wait_events(1)
        d.proc.send_signal(signal.SIGHUP)
        r = notify.wait_for("RELOADING=1", after=i + 1)
        notify.wait_for("READY=1", after=r)
        # A broken config on reload: logged, the running configuration kept.
        with open(d.config, "a") as f:
            f.write("\n[bogus]\n")
        d.proc.send_signal(signal.SIGHUP)
        r2 = notify.wait_for("RELOADING=1", after=r + 1)
        notify.wait_for("READY=1", after=r2)
        self.assertIsNone(d.proc.poll())
        self.assertIn("reload failed", d.log())
        self.assertEqual(d.probe()["registers"]["events_finished"], 1)
        self.assertEqual(d.stop(), 0)
        notify.wait_for("STOPPING=1")

    def test_replay_takes_the_logs_calibration_and_goes_quiet_at_the_end(self):
        # The log's own .bench.toml (gain 100 N/bar) beats [bench] in the config (66.7): the
        # daemon says which it used and publishes what brakefit replay computes with it.
        log = os.path.join(self.tmp, "own.log")
        shutil.copy(os.path.join(REC, "roller_2p2bar_fast.log"), log)
        with open(os.path.join(self.tmp, "own.bench.toml"), "w") as f:
            f.write(re.sub(r"brake_gain_n_per_bar = .*", "brake_gain_n_per_bar = 100", BENCH))
        ref = replay_reference(log)
        d = self.start(log, speed=0.0)
        p = d.wait_events(1)
        self.assertIn("calibration from " + os.path.join(self.tmp, "own.bench.toml"), d.log())
        hyb = next(r for r in ref[0]["results"] if r["method"] == "hybrid")
        self.assertEqual(p["registers"]["event.hybrid.D"], f32(hyb["D"]))
        # The replay has ended: the live registers hold no stale reading, status bit 1 says so.
        end = time.time() + 10
        while time.time() < end:
            r = d.probe()["registers"]
            if r["status_flags"] & 2:
                break
            time.sleep(0.1)
        self.assertTrue(r["status_flags"] & 2)
        for k in ("v_ref_mps", "v_wheel_mps", "slip_ratio", "pressure_bar"):
            self.assertTrue(r[k] is None or math.isnan(r[k]), f"{k} = {r[k]} after the replay ended")
        self.assertEqual(d.stop(), 0)

    def run_daemon(self, config_text):
        path = os.path.join(self.tmp, "bad.toml")
        with open(path, "w") as f:
            f.write(config_text)
        return subprocess.run([DAEMON, "--config", path], capture_output=True, text=True, timeout=20)

    def test_config_errors_exit_78_naming_the_key(self):
        base = f'[source]\nkind = "replay"\nfile = "x.log"\n{BENCH}\n'
        for extra, key in (("[store]\nretention = 3\n", "store.retention"),
                           ("[modbus_tcp]\nport = \"x\"\n", "modbus_tcp.port"),
                           ("[modbus_tcp]\nport = 99999\n", "modbus_tcp.port"),
                           ("[pipeline]\nstart_pressure_bar = 0\n", "pipeline.start_pressure_bar")):
            out = self.run_daemon(base + extra)
            self.assertEqual(out.returncode, 78, out.stderr)
            self.assertIn(f"'{key}'", out.stderr)
        out = subprocess.run([DAEMON, "--config", os.path.join(self.tmp, "missing.toml")],
                             capture_output=True, text=True)
        self.assertEqual(out.returncode, 78)
        self.assertIn("missing.toml", out.stderr)
        # The shipped config, with the model where this tree has it, passes --check; with its
        # model missing (not installed here) it fails naming the key, as the service start would.
        shipped = read_text(os.path.join(ROOT, "config", "brakefitd.toml"))
        model = os.path.join(ROOT, "data", "models", "default.json")
        for text, code in ((shipped.replace("/usr/share/brakefit/models/default.json", model), 0),
                           (shipped.replace("/usr/share/brakefit/models/", "/nonexistent/"), 78)):
            cfg = os.path.join(self.tmp, "shipped.toml")
            with open(cfg, "w") as f:
                f.write(text)
            out = subprocess.run([DAEMON, "--config", cfg, "--check"], capture_output=True, text=True)
            self.assertEqual(out.returncode, code, out.stderr)
            if code:
                self.assertIn("'daemon.model'", out.stderr)
                self.assertIn("/nonexistent/default.json", out.stderr)
            else:
                self.assertIn("ok (model", out.stdout)
        # A usage error is 64 (the README's table), not CLI11's own 109.
        out = subprocess.run([DAEMON, "--no-such-option"], capture_output=True, text=True)
        self.assertEqual(out.returncode, 64, out.stderr)
        self.assertIn("--no-such-option", out.stderr)

    def test_absent_sources_exit_nonzero_naming_them(self):
        store = os.path.join(self.tmp, "e.db")
        common = f'{BENCH}\n[modbus_tcp]\naddress = "127.0.0.1"\nport = 0\n[store]\npath = "{store}"\n'
        out = self.run_daemon(f'[source]\nkind = "socketcan"\ninterface = "bfcan9"\n{common}')
        self.assertEqual(out.returncode, 69, out.stderr)
        self.assertIn("bfcan9", out.stderr)
        out = self.run_daemon(f'[source]\nkind = "replay"\nfile = "{self.tmp}/none.log"\n{common}')
        self.assertEqual(out.returncode, 69, out.stderr)
        self.assertIn("none.log", out.stderr)
        rtu = '[modbus_rtu]\ndevice = "/dev/ttyBF404"\n'
        gpio = '[gpio]\nchip = "gpiochip77"\n'
        out = self.run_daemon(f'[source]\nkind = "gpio"\n{gpio}{rtu}{common}')
        self.assertEqual(out.returncode, 69, out.stderr)
        self.assertIn("/dev/ttyBF404", out.stderr)
        master, slave = os.openpty()  # a serial port that exists: now the gpiochip is missing
        try:
            rtu = f'[modbus_rtu]\ndevice = "{os.ttyname(slave)}"\n'
            out = self.run_daemon(f'[source]\nkind = "gpio"\n{gpio}{rtu}{common}')
            self.assertEqual(out.returncode, 69, out.stderr)
            self.assertIn("gpiochip77", out.stderr)
        finally:
            os.close(master)
            os.close(slave)

    def test_sensor_timeout_mid_event_aborts_it_and_the_daemon_carries_on(self):
        fast = read_log(os.path.join(REC, "roller_2p2bar_fast.log"))
        # The event runs from 1.04 s to 1.88 s: the bus goes silent at 1.4 s for 3 s.
        cut = fast[0][0] + 1_400_000
        part1 = [f for f in fast if f[0] < cut]
        path = os.path.join(self.tmp, "gap.log")
        write_log(path, concat([part1, read_log(os.path.join(REC, "roller_2p2bar_medium.log"))], gap_us=3_000_000))
        d = self.start(path, speed=2.0)
        saw_missing = False
        end = time.time() + 30
        while time.time() < end:
            r = d.probe()["registers"]
            saw_missing |= bool(r["status_flags"] & (1 << 4))  # pressure missing during the gap
            if r["events_finished"] >= 2:
                break
            time.sleep(0.05)
        self.assertEqual(r["events_finished"], 2, d.log())
        self.assertEqual(r["events_flagged"], 1)
        self.assertTrue(saw_missing)
        self.assertIn(r["event.end_reason"], (1, 2))  # the second event is whole and fitted
        self.assertIsNotNone(r["event.hybrid.B"])
        self.assertEqual(d.stop(), 0)
        st = stored(d.store)
        self.assertEqual(st[0]["event"]["end_reason"], "sensor_timeout")
        self.assertIn("aborted", st[0]["event"]["flags"])
        self.assertEqual(st[0]["event"]["results"], [])
        self.assertEqual(st[1]["event"]["flags"], [])
        self.assertTrue(st[1]["event"]["results"])

    def test_malformed_requests_and_a_hundred_clients_against_the_process(self):
        d = self.start(os.path.join(REC, "roller_2p2bar_fast.log"))
        d.wait_events(1)
        s = socket.create_connection(("127.0.0.1", d.port))
        s.sendall(bytes([0, 1, 0, 0, 0, 6, 1, 6, 0, 0, 0, 2]))  # write on a read-only map
        reply = s.recv(64)
        self.assertEqual(reply[7:9], bytes([0x86, 0x01]))
        s.sendall(bytes([0, 2, 0, 7, 0, 6, 1, 4, 0, 0, 0, 1]))  # protocol id 7
        self.assertEqual(s.recv(64), b"")
        s.close()
        # A hundred hosts (127.0.0.2-101): each is served, whatever the per-address limit.
        socks = [socket.create_connection(("127.0.0.1", d.port), source_address=(f"127.0.0.{i + 2}", 0))
                 for i in range(100)]
        for i, c in enumerate(socks):
            c.sendall(bytes([0, i, 0, 0, 0, 6, 1, 4, 0, 101, 0, 2]))
        ok = 0
        for i, c in enumerate(socks):
            c.settimeout(5)
            r = c.recv(64)
            ok += len(r) == 13 and r[1] == i and struct.unpack(">I", r[9:13])[0] == 1
            c.close()
        self.assertEqual(ok, 100)
        self.assertTrue(d.probe()["consistent"])
        self.assertEqual(d.stop(), 0)

    def test_kill_9_during_an_event_then_restart_loses_no_finished_event(self):
        log = self.three_events_log()
        store = os.path.join(self.tmp, "k.db")
        d = self.start(log, speed=2.0, store=store)
        end = time.time() + 40
        while time.time() < end:
            r = d.probe()["registers"]
            if r["events_finished"] >= 1 and r["status_flags"] & (1 << 5):
                break
            time.sleep(0.02)
        published = r["events_finished"]
        self.assertGreaterEqual(published, 1)
        self.assertTrue(r["status_flags"] & (1 << 5), "no event was running when killed")
        d.proc.kill()
        d.proc.wait()
        con = sqlite3.connect(store)
        self.assertEqual(con.execute("PRAGMA integrity_check").fetchone()[0], "ok")
        n = con.execute("SELECT COUNT(*) FROM events").fetchone()[0]
        con.close()
        self.assertGreaterEqual(n, published)  # committed before published
        self.assertEqual(n, r["event.id"])
        d2 = self.start(log, speed=0, store=store, exit_at_end=True)
        self.assertEqual(d2.proc.wait(timeout=60), 0)
        st = stored(store)
        self.assertEqual([s["id"] for s in st], list(range(1, n + 4)))
        self.assertTrue(all(s["event"]["results"] for s in st))

    def test_systemd_unit_verifies_and_is_hardened(self):
        if not shutil.which("systemd-analyze"):
            self.skipTest("systemd-analyze is not installed")
        unit = read_text(os.path.join(ROOT, "systemd", "brakefitd.service"))
        path = os.path.join(self.tmp, "brakefitd.service")
        with open(path, "w") as f:
            f.write(unit.replace("/usr/sbin/brakefitd", DAEMON))
        # man:brakefitd(8) is checked where it is installed (tests/package/test_deb.sh).
        out = subprocess.run(["systemd-analyze", "verify", "--man=no", path], capture_output=True,
                             text=True, cwd=self.tmp)
        self.assertEqual(out.returncode, 0, out.stdout + out.stderr)
        out = subprocess.run(["systemd-analyze", "security", "--offline=yes", path],
                             capture_output=True, text=True, cwd=self.tmp)
        m = re.search(r"Overall exposure level for brakefitd.service: ([\d.]+)", out.stdout)
        self.assertIsNotNone(m, out.stdout + out.stderr)
        self.assertLessEqual(float(m.group(1)), 3.0)
        for key in ("Type=notify", "WatchdogSec=", "Restart=on-failure", "ProtectSystem=strict",
                    "StateDirectory=brakefit", "AF_CAN", "DeviceAllow=/dev/gpiochip0",
                    "ExecReload=/bin/kill -HUP $MAINPID"):
            self.assertIn(key, unit)

    def test_cmake_install_places_everything(self):
        build = os.path.dirname(os.path.dirname(DAEMON))
        dest = os.path.join(self.tmp, "root")
        out = subprocess.run(["cmake", "--install", build, "--prefix", "/usr"],
                             env=dict(os.environ, DESTDIR=dest), capture_output=True, text=True)
        self.assertEqual(out.returncode, 0, out.stderr)
        for p in ("usr/sbin/brakefitd", "usr/bin/brakefit", "lib/systemd/system/brakefitd.service",
                  "lib/systemd/system/brakefit-sync.service",
                  "etc/brakefit/brakefitd.toml", "lib/udev/rules.d/60-brakefit.rules",
                  "usr/lib/tmpfiles.d/brakefit.conf", "usr/share/brakefit/models/default.json",
                  "usr/share/brakefit/modbus_registers.csv"):
            self.assertTrue(os.path.exists(os.path.join(dest, p)), p)
        cfg = os.path.join(dest, "etc/brakefit/brakefitd.toml")
        text = read_text(cfg)
        self.assertIn('model = "/usr/share/brakefit/models/default.json"', text)
        with open(cfg, "w") as f:  # checked outside that root: its paths are under dest
            f.write(text.replace('"/usr/share/', f'"{dest}/usr/share/'))
        out = subprocess.run([DAEMON, "--config", cfg, "--check"], capture_output=True, text=True)
        self.assertEqual(out.returncode, 0, out.stderr)


if __name__ == "__main__":
    unittest.main()
