"""The store never loses a finished event, as a hostile operator would try it on real brakefitd
processes: kill -9 aimed at the moment an event closes (each event recovered once, never twice),
two daemons on one store, a stall mid-event, a spill path that cannot be written, a stop that
cannot store or spill its events, crafted spill files at start, a torn write-ahead log, and a
store whose -wal and -shm the daemon's user cannot write."""
import os
import re
import shutil
import signal
import sqlite3
import subprocess
import time
import unittest

import test_daemon
import json

from daemontools import BENCH, DAEMON, MODEL, stored
from logtools import read_text
from test_faults import hold_lock

CLOSED = re.compile(rb"^info event (\d+) closed \(", re.M)


def uids(db):
    con = sqlite3.connect(db)
    try:
        return [r[0] for r in con.execute("SELECT uid FROM events ORDER BY id")]
    finally:
        con.close()


class DurabilityTest(unittest.TestCase):
    setUp = test_daemon.DaemonTest.setUp
    tearDown = test_daemon.DaemonTest.tearDown
    start = test_daemon.DaemonTest.start
    three_events_log = test_daemon.DaemonTest.three_events_log

    def quiet_log(self):
        """A log with no brake event: a start on it only commits what earlier runs left."""
        path = os.path.join(self.tmp, "quiet.log")
        with open(path, "w") as f:
            f.write("(1700000000.000000) can0 7FF#00\n(1700000000.100000) can0 7FF#00\n")
        return path

    def config(self, name, log, store, source="", daemon=""):
        """A brakefitd config run directly (not through the helper, which waits for its port)."""
        cfg = os.path.join(self.tmp, f"{name}.toml")
        with open(cfg, "w") as f:
            f.write(f'[daemon]\nmodel = "{MODEL}"\n{daemon}[source]\nkind = "replay"\n'
                    f'file = "{log}"\n{source}{BENCH}\n'
                    f'[modbus_tcp]\naddress = "127.0.0.1"\nport = 0\n'
                    f'[store]\npath = "{store}"\nmin_free_mb = 0\n')
        return cfg

    def recover(self, store):
        """One start on a log without events: it commits what earlier runs left, then exits (too
        soon for the helper's wait for the port, so run here)."""
        cfg = self.config("recover", self.quiet_log(), store, "speed = 0\nexit_at_end = true\n")
        r = subprocess.run([DAEMON, "--config", cfg], capture_output=True, text=True, timeout=120)
        self.assertEqual(r.returncode, 0, r.stderr)
        return r.stderr

    def kill_at_close(self, log, store, delay_s):
        """Starts brakefitd and kills it -9 delay_s after its first 'event N closed' line."""
        d = self.start(log, store=store, speed=4.0)
        path = os.path.join(self.tmp, "brakefitd.log")
        seen = os.path.getsize(path) if os.path.exists(path) else 0
        end = time.time() + 30
        with open(path, "rb") as f:
            f.seek(seen)
            buf = b""
            while time.time() < end:
                buf += f.read()
                if CLOSED.search(buf):
                    break
                time.sleep(0.0002)
        self.assertTrue(CLOSED.search(buf), d.log())
        if delay_s:
            time.sleep(delay_s)
        d.proc.kill()
        d.proc.wait()

    def test_kill_9_as_an_event_closes_loses_it_never_and_stores_it_once(self):
        log = self.three_events_log()
        store = os.path.join(self.tmp, "k.db")
        for delay in (0, 0.0005, 0.001, 0.002, 0.003, 0.005):
            self.kill_at_close(log, store, delay)
        closed = len(CLOSED.findall(read_text(os.path.join(self.tmp, "brakefitd.log")).encode()))
        self.recover(store)
        u = uids(store)
        self.assertEqual(len(u), len(set(u)), "an event stored twice")
        # Every event that closed is stored: the recovery's own log adds none (no events in it).
        self.assertEqual(len(u), closed)
        self.assertEqual([f for f in os.listdir(store + ".spill") if f.endswith(".cbor")], [])
        self.assertTrue(all(s["event"]["results"] for s in stored(store)))

    def test_a_second_daemon_on_one_store_is_refused_with_75(self):
        log = self.three_events_log()
        store = os.path.join(self.tmp, "one.db")
        first = self.start(log, store=store, speed=1.0)
        cfg = os.path.join(self.tmp, "second.toml")
        shutil.copy(first.config, cfg)
        with open(cfg) as f:
            text = f.read().replace(f"port = {first.port}", "port = 0")
        with open(cfg, "w") as f:
            f.write(text)
        r = subprocess.run([DAEMON, "--config", cfg], capture_output=True, text=True, timeout=30)
        self.assertEqual(r.returncode, 75, r.stderr)
        self.assertIn(f"another brakefitd (pid {first.proc.pid}) uses this store", r.stderr)
        self.assertIsNone(first.proc.poll())

    def test_a_stall_mid_event_ends_no_event(self):
        log = self.three_events_log()
        store = os.path.join(self.tmp, "stall.db")
        d = self.start(log, store=store, speed=1.0)
        end = time.time() + 20
        while time.time() < end:  # the first event starts about 1 s into the log: stop inside it
            if d.probe()["registers"]["status_flags"] & (1 << 5):
                break
            time.sleep(0.02)
        d.proc.send_signal(signal.SIGSTOP)
        time.sleep(0.8)
        d.proc.send_signal(signal.SIGCONT)
        d.wait_events(1, timeout=30)
        self.assertEqual(d.stop(), 0)
        text = read_text(os.path.join(self.tmp, "brakefitd.log"))
        st = stored(store)
        self.assertGreaterEqual(len(st), 1)
        self.assertEqual(st[0]["event"]["end_reason"], "switch_off_slip", text)
        self.assertNotIn("sensor timeout", text)

    def test_a_spill_path_that_is_a_file_refuses_the_start(self):
        store = os.path.join(self.tmp, "s.db")
        with open(store + ".spill", "w") as f:
            f.write("x")
        try:  # the listening socket is bound before the checks: it may answer, then close
            d = self.start(self.three_events_log(), store=store)
        except AssertionError as e:
            self.assertIn("exited 73", str(e))
            self.assertIn("cannot create the spill directory", str(e))
            return
        self.assertEqual(d.proc.wait(timeout=30), 73, d.log())
        self.assertIn("cannot create the spill directory", d.log())

    def test_a_stop_that_can_neither_store_nor_spill_exits_73_counting_the_loss(self):
        log = self.three_events_log()
        store = os.path.join(self.tmp, "lost.db")
        d = self.start(log, store=store, speed=4.0)
        d.probe()  # answered: the start's checks are behind it
        lock = hold_lock(store)
        shutil.rmtree(store + ".spill")
        with open(store + ".spill", "w") as f:  # the journal's directory is gone: a file there
            f.write("x")
        d.wait_events(3, timeout=60)
        d.proc.send_signal(signal.SIGTERM)
        rc = d.proc.wait(timeout=15)
        lock.rollback()
        lock.close()
        self.assertEqual(rc, 73, d.log())
        self.assertIn("3 finished event(s) lost in this run", d.log())
        self.assertRegex(d.log(), r"event \(pipeline id 1\) lost|cannot journal event")
        with open(d.stats) as f:
            self.assertEqual(json.load(f)["events_lost"], 3)

    def test_the_journal_may_live_on_another_filesystem(self):
        log = self.three_events_log()
        store = os.path.join(self.tmp, "j.db")
        journal = os.path.join(self.tmp, "elsewhere", "journal")
        d = self.start(log, store=store, speed=4.0, extra=f'spill_dir = "{journal}"\n')
        d.probe()
        lock = hold_lock(store)
        d.wait_events(3, timeout=60)
        self.assertEqual(len([f for f in os.listdir(journal) if f.endswith(".cbor")]), 3)
        self.assertFalse(os.path.exists(store + ".spill"))
        lock.rollback()
        lock.close()
        self.assertEqual(d.stop(), 0)
        self.assertEqual(len(stored(store)), 3)
        self.assertEqual([f for f in os.listdir(journal) if f.endswith(".cbor")], [])

    @unittest.skipUnless(os.geteuid() == 0, "needs root to mount a 512 KB tmpfs for the store")
    def test_a_full_small_disk_a_held_lock_and_a_stop_lose_nothing_silently(self):
        mnt = os.path.join(self.tmp, "small")
        os.makedirs(mnt)
        r = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=512k", "tmpfs", mnt],
                           capture_output=True, text=True)
        if r.returncode != 0:
            self.skipTest(f"cannot mount a tmpfs here: {r.stderr.strip()}")
        try:
            log = self.three_events_log()
            store = os.path.join(mnt, "events.db")
            stats = os.path.join(self.tmp, "small.stats.json")
            err = os.path.join(self.tmp, "small.log")
            cfg = self.config("small", log, store, "speed = 8\nloop = true\n",
                              f'stats_file = "{stats}"\n')
            with open(err, "w") as ef:
                proc = subprocess.Popen([DAEMON, "--config", cfg], stdout=ef, stderr=ef)
            time.sleep(1.0)
            lock = hold_lock(store)
            time.sleep(6.0)
            proc.send_signal(signal.SIGTERM)
            rc = proc.wait(timeout=30)
            lock.rollback()
            lock.close()
            text = read_text(err)
            closed = len(CLOSED.findall(text.encode()))
            with open(stats) as f:
                lost = json.load(f)["events_lost"]
            spilled = len([x for x in os.listdir(store + ".spill") if x.endswith(".cbor")])
            rows = len(stored(store))
            self.assertGreater(closed, 5, text)
            # Each finished event is stored, waits in a journal file, or is counted lost.
            self.assertEqual(rows + spilled + lost, closed, text)
            if lost:
                self.assertEqual(rc, 73, text)
                self.assertIn(f"{lost} finished event(s) lost in this run", text)
            else:
                self.assertEqual(rc, 0, text)
        finally:
            subprocess.run(["umount", "-l", mnt])

    def test_crafted_spill_files_at_start_strand_nothing(self):
        log = self.three_events_log()
        store = os.path.join(self.tmp, "c.db")
        d = self.start(log, store=store, speed=4.0)
        lock = hold_lock(store)
        d.wait_events(1, timeout=60)
        d.proc.kill()
        d.proc.wait()
        lock.rollback()
        lock.close()
        spill = store + ".spill"
        valid = sorted(f for f in os.listdir(spill) if f.endswith(".cbor"))
        self.assertGreaterEqual(len(valid), 1)
        with open(os.path.join(spill, "00000000000000000000-deep.cbor"), "wb") as f:
            f.write(b"\x81" * (1 << 20) + b"\x00")
        os.mkfifo(os.path.join(spill, "00000000000000000000-fifo.cbor"))
        os.symlink("/dev/zero", os.path.join(spill, "00000000000000000000-zero.cbor"))
        t0 = time.time()
        log_text = self.recover(store)
        self.assertLess(time.time() - t0, 30)
        self.assertEqual(len(stored(store)), len(valid))
        for bad in ("deep", "fifo", "zero"):
            self.assertTrue(os.path.lexists(os.path.join(spill, f"00000000000000000000-{bad}.cbor.bad")))
        self.assertIn("nested deeper than", log_text)
        self.assertIn("a FIFO", log_text)
        self.assertIn("a symbolic link", log_text)

    def test_a_torn_write_ahead_log_loses_no_committed_event_and_is_kept_aside(self):
        log = self.three_events_log()
        store = os.path.join(self.tmp, "w.db")
        d = self.start(log, store=store, speed=0.0)
        d.wait_events(3, timeout=60)
        time.sleep(0.3)
        d.proc.kill()
        d.proc.wait()
        wal = store + "-wal"
        self.assertGreater(os.path.getsize(wal), 1000)
        # Every commit was checkpointed: the main file alone holds the three events.
        backup = os.path.join(self.tmp, "backup.db")
        shutil.copy(store, backup)
        self.assertEqual(len(stored(backup)), 3)
        os.truncate(wal, os.path.getsize(wal) - 1000)
        log_text = self.recover(store)
        self.assertEqual(len(stored(store)), 3)
        self.assertIn("the write-ahead log does not end cleanly", log_text)
        self.assertTrue([f for f in os.listdir(self.tmp) if f.startswith("w.db-wal.kept-")])

    @unittest.skipUnless(os.geteuid() == 0 and shutil.which("setpriv"),
                         "needs root and setpriv to run brakefitd as another user")
    def test_a_store_whose_wal_the_daemon_cannot_write_refuses_before_ready(self):
        log = self.three_events_log()
        store = os.path.join(self.tmp, "ro.db")
        self.recover(store)  # a store with brakefitd's schema, as a root run left it
        con = sqlite3.connect(store)  # a root reader holds it open: its -wal and -shm are root's
        con.execute("SELECT COUNT(*) FROM events").fetchone()
        os.chmod(self.tmp, 0o777)
        # The database is the daemon user's; its -wal and -shm (made by root) are not.
        import pwd
        nobody = pwd.getpwnam("nobody")
        os.chown(store, nobody.pw_uid, nobody.pw_gid)
        for f in (store + "-wal", store + "-shm"):
            self.assertTrue(os.path.exists(f))
            os.chmod(f, 0o644)
        os.chmod(log, 0o644)
        cfg_dir = os.path.join(self.tmp, "cfg")
        os.makedirs(cfg_dir)
        model = os.path.join(cfg_dir, "model.json")
        shutil.copy(MODEL, model)
        os.chmod(model, 0o644)
        probe = self.start(log, store=os.path.join(self.tmp, "other.db"))
        probe.stop()
        with open(probe.config) as f:
            text = f.read().replace(os.path.join(self.tmp, "other.db"), store)
        text = text.replace(MODEL, model)
        text = re.sub(r'stats_file = "[^"]*"\n', "", text)
        cfg = os.path.join(cfg_dir, "ro.toml")
        with open(cfg, "w") as f:
            f.write(text)
        os.chmod(cfg_dir, 0o755)
        os.chmod(cfg, 0o644)
        r = subprocess.run(["setpriv", "--reuid=nobody", "--regid=nogroup", "--clear-groups",
                            DAEMON, "--config", cfg], capture_output=True, text=True, timeout=30)
        con.close()
        self.assertEqual(r.returncode, 73, r.stderr)
        self.assertRegex(r.stderr, r"ro\.db-(wal|shm): Permission denied")
        self.assertNotIn("brakefitd: source", r.stderr)  # never got as far as listening


if __name__ == "__main__":
    unittest.main()
