"""Helpers for the daemon's process tests: the binaries and data, a NOTIFY_SOCKET listener, a
brakefitd process with its log, `brakefit replay` as the reference and the store as listed by
`brakefit events`."""
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

from logtools import concat, read_log, read_text, write_log

DAEMON = os.environ["BRAKEFITD_BIN"]
CLI = os.environ["BRAKEFIT_BIN"]
ROOT = os.environ["BRAKEFIT_ROOT"]
PROBE = os.environ["MODBUS_PROBE_BIN"]
REC = os.path.join(ROOT, "data", "recorded")
MODEL = os.path.join(ROOT, "data", "models", "default.json")


BENCH = read_text(os.path.join(REC, "roller_2p2bar_fast.bench.toml"))
METHODS = ["som", "mlp", "lm", "hybrid"]


def f32(x):
    return struct.unpack(">f", struct.pack(">f", x))[0]


def free_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


class Notify:
    """Our own NOTIFY_SOCKET: collects what the daemon sends."""

    def __init__(self, path):
        self.path = path
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        self.sock.bind(path)
        self.sock.settimeout(0.1)
        self.messages = []

    def pump(self):
        """One message, waiting at most 0.1 s."""
        try:
            self.messages.append(self.sock.recv(4096).decode())
        except socket.timeout:
            pass

    def wait_for(self, text, timeout=10.0, after=0):
        end = time.time() + timeout
        while time.time() < end:
            self.pump()
            for i, m in enumerate(self.messages[after:], after):
                if text in m.split("\n"):
                    return i
        raise AssertionError(f"no {text!r} from the daemon; got {self.messages}")


class Daemon:
    def __init__(self, tmp, source, *, store=None, speed=0.0, exit_at_end=False, extra="",
                 env=None, port=None, min_free_mb=0):
        self.tmp = tmp
        self.port = port or free_port()
        self.store = store or os.path.join(tmp, "events.db")
        self.stats = os.path.join(tmp, "stats.json")
        self.config = os.path.join(tmp, "brakefitd.toml")
        with open(self.config, "w") as f:
            f.write(f'[daemon]\nmodel = "{MODEL}"\nstats_file = "{self.stats}"\n'
                    f'[source]\nkind = "replay"\nfile = "{source}"\nspeed = {speed}\n'
                    f'exit_at_end = {"true" if exit_at_end else "false"}\n'
                    f'{BENCH}\n[modbus_tcp]\naddress = "127.0.0.1"\nport = {self.port}\n'
                    f'[store]\npath = "{self.store}"\nmin_free_mb = {min_free_mb}\n{extra}')
        self.env = dict(os.environ, **(env or {}))
        self.err = open(os.path.join(tmp, "brakefitd.log"), "a")
        self.proc = subprocess.Popen([DAEMON, "--config", self.config], env=self.env,
                                     stdout=self.err, stderr=self.err)
        self.wait_port()

    def wait_port(self, timeout=10):
        end = time.time() + timeout
        while time.time() < end:
            if self.proc.poll() is not None:
                raise AssertionError(f"brakefitd exited {self.proc.returncode}: {self.log()}")
            try:
                socket.create_connection(("127.0.0.1", self.port), 0.2).close()
                return
            except OSError:
                time.sleep(0.05)
        raise AssertionError("brakefitd did not listen")

    def probe(self):
        out = subprocess.run([PROBE, "--port", str(self.port), "read"], capture_output=True,
                             text=True, timeout=10)
        assert out.returncode == 0, out.stderr
        return json.loads(out.stdout)

    def wait_events(self, n, timeout=60):
        end = time.time() + timeout
        while time.time() < end:
            p = self.probe()
            if p["registers"]["events_finished"] >= n:
                return p
            time.sleep(0.1)
        raise AssertionError(f"fewer than {n} events published: {self.log()}")

    def log(self):
        self.err.flush()
        return read_text(os.path.join(self.tmp, "brakefitd.log"))

    def stop(self):
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
        rc = self.proc.wait(timeout=15)
        self.err.close()
        return rc


def replay_reference(log):
    bench = os.path.splitext(log)[0] + ".bench.toml"
    args = ["--bench", bench] if os.path.exists(bench) else []
    out = subprocess.run([CLI, "replay", "--json", "--model", MODEL, *args, log],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    return [json.loads(l) for l in out.stdout.splitlines()]


def stored(db):
    out = subprocess.run([CLI, "events", "--db", db, "list", "--json", "--limit", "1000"],
                         capture_output=True, text=True, timeout=30)
    assert out.returncode == 0, out.stderr
    return sorted((json.loads(l) for l in out.stdout.splitlines()), key=lambda d: d["id"])
