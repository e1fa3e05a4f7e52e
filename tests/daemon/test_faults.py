"""brakefitd under the faults docs/daemon.md makes promises about, as real processes on loopback:
a store another process holds locked (nothing published until stored; retried; spilled; a kill -9
while locked loses nothing), reloads with each kind of broken file (the running model kept, the
next event fitted with it), a restart (the last stored event restored into the registers, the
sequence continues), a host holding every connection it may (another answered within 100 ms),
and a disk below min_free_mb (results kept, samples not, flagged)."""
import os
import shutil
import signal
import socket
import sqlite3
import struct
import subprocess
import time
import unittest

import test_daemon
from daemontools import BENCH, DAEMON, MODEL, REC, replay_reference, stored


def hold_lock(db):
    """Another process's writer lock on the store (what `sqlite3 db 'BEGIN IMMEDIATE'` holds)."""
    con = sqlite3.connect(db, isolation_level=None, timeout=5)
    con.execute("PRAGMA journal_mode=WAL")
    con.execute("BEGIN IMMEDIATE")
    return con


class FaultTest(unittest.TestCase):
    # The helpers of test_daemon's DaemonTest, without running its tests a second time.
    setUp = test_daemon.DaemonTest.setUp
    tearDown = test_daemon.DaemonTest.tearDown
    start = test_daemon.DaemonTest.start
    three_events_log = test_daemon.DaemonTest.three_events_log

    def wait_until(self, d, pred, timeout=30, what="condition"):
        end = time.time() + timeout
        while time.time() < end:
            r = d.probe()["registers"]
            if pred(r):
                return r
            time.sleep(0.05)
        raise AssertionError(f"timed out waiting for {what}: {r}\n{d.log()}")

    def test_a_locked_store_publishes_nothing_until_each_event_is_stored(self):
        log = self.three_events_log()
        store = os.path.join(self.tmp, "locked.db")
        d = self.start(log, store=store, speed=4.0)
        lock = hold_lock(store)  # before the first event (about 1 s into the log)
        self.assertEqual(d.probe()["registers"]["events_finished"], 0)
        r = self.wait_until(d, lambda r: r["events_finished"] == 3, what="3 events finished")
        time.sleep(1.0)  # a few retries
        r = d.probe()["registers"]
        # Finished but not stored: nothing published, all waiting, spilled (hold_in_memory 0).
        self.assertEqual(r["event.seq"], 0)
        self.assertEqual(r["event.id"], 0)
        self.assertEqual(r["events_waiting"], 3)
        self.assertEqual(r["events_spilled"], 3)
        self.assertTrue(r["status_flags"] & (1 << 7) and r["status_flags"] & (1 << 10))
        self.assertGreaterEqual(r["store_failures"], 2)
        self.assertEqual(len(os.listdir(store + ".spill")), 3)
        lock.rollback()
        lock.close()
        # The block is posted with each commit, the counters with the next status (<= 50 ms).
        r = self.wait_until(d, lambda r: r["event.seq"] == 3 and r["events_waiting"] == 0,
                            timeout=15, what="publication")
        self.assertEqual(r["event.id"], 3)
        self.assertEqual(r["events_waiting"], 0)
        self.assertFalse(r["status_flags"] & ((1 << 7) | (1 << 10)))
        self.assertEqual(os.listdir(store + ".spill"), [])
        self.assertIn("database is locked", d.log())
        self.assertIn("store works again", d.log())
        self.assertEqual(d.stop(), 0)
        ref = replay_reference(log)
        st = stored(store)
        self.assertEqual([s["id"] for s in st], [1, 2, 3])
        self.assertEqual([s["event"]["results"] for s in st], [x["results"] for x in ref])

    def test_kill_9_while_the_store_is_locked_loses_no_finished_event(self):
        log = self.three_events_log()
        store = os.path.join(self.tmp, "k.db")
        d = self.start(log, store=store, speed=4.0)
        lock = hold_lock(store)
        self.assertEqual(d.probe()["registers"]["events_finished"], 0)
        self.wait_until(d, lambda r: r["events_spilled"] == 3, what="3 events spilled")
        d.proc.kill()
        d.proc.wait()
        lock.rollback()
        lock.close()
        # The restart commits the spilled events first (then replays the log again: 3 more).
        d2 = self.start(log, store=store, exit_at_end=True)
        self.assertEqual(d2.proc.wait(timeout=60), 0, d2.log())
        st = stored(store)
        self.assertEqual([s["id"] for s in st], list(range(1, 7)))
        self.assertTrue(all(s["event"]["results"] for s in st))
        self.assertEqual(st[0]["event"]["results"], st[3]["event"]["results"])
        self.assertEqual(os.listdir(store + ".spill"), [])
        self.assertIn("spilled by an earlier run", d2.log())

    def test_reload_with_each_kind_of_broken_file_keeps_the_running_model(self):
        slow = os.path.join(self.tmp, "slow.log")
        shutil.copy(self.three_events_log(), slow)
        shutil.copy(os.path.join(self.tmp, "three.bench.toml"), os.path.join(self.tmp, "slow.bench.toml"))
        model = os.path.join(self.tmp, "model.json")
        shutil.copy(MODEL, model)
        d = self.start(slow, speed=1.0)
        with open(d.config) as f:
            good = f.read().replace(f'model = "{MODEL}"', f'model = "{model}"')
        with open(d.config, "w") as f:
            f.write(good)
        d.proc.send_signal(signal.SIGHUP)
        self.wait_until(d, lambda r: r["events_finished"] >= 0, what="probe")
        time.sleep(0.3)
        corrupt = os.path.join(self.tmp, "corrupt.json")
        with open(model) as f:
            text = f.read()
        with open(corrupt, "w") as f:
            f.write(text[: len(text) // 2])
        badsum = os.path.join(self.tmp, "badsum.json")
        with open(badsum, "w") as f:
            f.write(text.replace('"brakefit_version": "', '"brakefit_version": "x', 1))
        overflow = os.path.join(self.tmp, "overflow.json")
        with open(overflow, "w") as f:
            f.write('{"schema": 1e999}')
        for broken in (os.path.join(self.tmp, "missing.json"), corrupt, badsum, overflow,
                       "/proc/self/mem"):
            with open(d.config, "w") as f:
                f.write(good.replace(f'model = "{model}"', f'model = "{broken}"'))
            n = d.log().count("reload failed")
            d.proc.send_signal(signal.SIGHUP)
            end = time.time() + 10
            while d.log().count("reload failed") == n and time.time() < end:
                time.sleep(0.05)
            self.assertEqual(d.log().count("reload failed"), n + 1, broken)
            self.assertIsNone(d.proc.poll(), d.log())
        # A broken config (not TOML) too.
        with open(d.config, "w") as f:
            f.write(good + "\n[[[\n")
        d.proc.send_signal(signal.SIGHUP)
        # The events after the failed reloads are fitted with the running model.
        r = self.wait_until(d, lambda r: r["events_finished"] >= 3, timeout=60, what="3 events")
        self.assertIsNone(d.proc.poll(), d.log())
        ref = replay_reference(slow)
        h = int(ref[-1]["model_hash"].split(":")[1][:8], 16)
        self.assertEqual(r["event.model_hash"], h)
        self.assertFalse(r["event.flags"] & (1 << 3), "the event was not fitted")
        self.assertNotIn("AddressSanitizer", d.log())
        self.assertEqual(d.stop(), 0)
        self.assertEqual(len(stored(d.store)), 3)

    def test_a_restart_restores_the_last_event_and_continues_the_sequence(self):
        log = self.three_events_log()
        store = os.path.join(self.tmp, "r.db")
        d = self.start(log, store=store, exit_at_end=True)
        self.assertEqual(d.proc.wait(timeout=60), 0)
        before = stored(store)[-1]
        # Restart on a log that takes a while to reach its first event: the block is there at once.
        d2 = self.start(log, store=store, speed=1.0)
        p = d2.probe()
        r = p["registers"]
        self.assertTrue(p["consistent"])
        self.assertEqual(r["event.seq"], 3)
        self.assertEqual(r["event.id"], 3)
        self.assertEqual(r["events_finished"], 0)
        hyb = next(x for x in before["event"]["results"] if x["method"] == "hybrid")
        self.assertEqual(r["event.hybrid.B"], struct.unpack(">f", struct.pack(">f", hyb["B"]))[0])
        r = self.wait_until(d2, lambda r: r["events_finished"] >= 1, what="a new event")
        self.assertEqual(r["event.seq"], 4)
        self.assertEqual(r["event.id"], 4)
        self.assertEqual(d2.stop(), 0)

    def test_a_host_holding_every_connection_it_may_does_not_lock_others_out(self):
        d = self.start(os.path.join(REC, "roller_2p2bar_fast.log"))
        d.wait_events(1)
        hog = []
        for _ in range(140):  # more than max_clients (128) from one address
            try:
                hog.append(socket.create_connection(("127.0.0.1", d.port), 1))
            except OSError:
                break
        time.sleep(0.3)
        t0 = time.perf_counter()
        s = socket.create_connection(("127.0.0.1", d.port), 1, source_address=("127.0.0.2", 0))
        s.sendall(bytes([0, 9, 0, 0, 0, 6, 1, 4, 0, 0, 0, 1]))
        s.settimeout(1)
        reply = s.recv(64)
        ms = (time.perf_counter() - t0) * 1000
        s.close()
        self.assertEqual(reply[:2], bytes([0, 9]))
        self.assertLess(ms, 100)
        print(f"\nnew host answered in {ms:.2f} ms while 127.0.0.1 held {len(hog)} sockets")
        for h in hog:
            h.close()
        time.sleep(0.2)
        r = d.probe()["registers"]
        self.assertGreaterEqual(r["modbus_rejected"], len(hog) - 16)
        self.assertIn("modbus_tcp: refused 127.0.0.1 (per-address limit)", d.log())
        self.assertEqual(d.stop(), 0)

    def test_a_disk_below_min_free_keeps_results_and_flags_the_missing_samples(self):
        # min_free_mb far above any disk: the event is stored without its samples, and says so.
        d = self.start(os.path.join(REC, "roller_2p2bar_fast.log"), min_free_mb=1e7)
        r = d.wait_events(1)["registers"]
        self.assertTrue(r["status_flags"] & (1 << 6))
        self.assertTrue(r["event.flags"] & (1 << 4))
        self.assertEqual(r["event.id"], 1)
        self.assertEqual(d.stop(), 0)
        st = stored(d.store)
        self.assertEqual(len(st), 1)
        self.assertFalse(st[0]["samples_stored"])
        self.assertTrue(st[0]["event"]["results"])

    def run_daemon(self, body):
        path = os.path.join(self.tmp, "one.toml")
        with open(path, "wb") as f:
            f.write(body if isinstance(body, bytes) else body.encode())
        return subprocess.run([DAEMON, "--config", path], capture_output=True,
                              text=True, timeout=30)

    def test_bad_files_at_start_exit_with_their_own_code_naming_them(self):
        good = os.path.join(REC, "roller_2p2bar_fast.log")
        bad = os.path.join(self.tmp, "bad.log")
        with open(good) as f:
            lines = f.read().splitlines()
        lines[10] = "(1700000000.1) can0 100#00"
        with open(bad, "w") as f:
            f.write("\n".join(lines) + "\n")
        common = f'{BENCH}\n[modbus_tcp]\naddress = "127.0.0.1"\nport = 0\n'
        # A replay log with one bad line: data error 65 naming FILE:LINE (not 69 "absent").
        out = self.run_daemon(f'[source]\nkind = "replay"\nfile = "{bad}"\n{common}'
                              f'[store]\npath = "{self.tmp}/e.db"\n')
        self.assertEqual(out.returncode, 65, out.stderr)
        self.assertIn(f"{bad}:11:", out.stderr)
        # A store under a regular file: 73 with the system's reason.
        afile = os.path.join(self.tmp, "afile")
        open(afile, "w").close()
        out = self.run_daemon(f'[source]\nkind = "replay"\nfile = "{good}"\n{common}'
                              f'[store]\npath = "{afile}/sub/e.db"\n')
        self.assertEqual(out.returncode, 73, out.stderr)
        self.assertIn("Not a directory", out.stderr)
        # A directory the service user may not write: "Permission denied", not SQLite's "unable
        # to open database file". Run as nobody (root writes anywhere).
        if os.geteuid() == 0 and shutil.which("setpriv"):
            locked = os.path.join(self.tmp, "rootonly")
            os.mkdir(locked, 0o755)
            os.chmod(self.tmp, 0o755)
            path = os.path.join(self.tmp, "one.toml")
            with open(path, "w") as f:
                f.write(f'[source]\nkind = "replay"\nfile = "{good}"\n{common}'
                        f'[store]\npath = "{locked}/e.db"\n')
            os.chmod(path, 0o644)
            out = subprocess.run(["setpriv", "--reuid=nobody", "--regid=nogroup", "--clear-groups",
                                  DAEMON, "--config", path], capture_output=True,
                                 text=True, timeout=30)
            self.assertEqual(out.returncode, 73, out.stderr)
            self.assertIn("Permission denied", out.stderr)
        # A model beyond double and a config that is not text: 78 naming the file.
        model = os.path.join(self.tmp, "m.json")
        with open(model, "w") as f:
            f.write('{"schema": 1e999}')
        out = self.run_daemon(f'[daemon]\nmodel = "{model}"\n[source]\nkind = "replay"\n'
                              f'file = "{good}"\n{common}[store]\npath = "{self.tmp}/e.db"\n')
        self.assertEqual(out.returncode, 78, out.stderr)
        self.assertIn("m.json: not a brakefit model", out.stderr)
        out = self.run_daemon(b'[source]\nkind = "replay\xff"\n')
        self.assertEqual(out.returncode, 78, out.stderr)
        self.assertIn("invalid UTF-8", out.stderr)


if __name__ == "__main__":
    unittest.main()
