#!/usr/bin/env python3
"""brakefitd at live rates: CPU and memory, event-end to publish latency, Modbus requests/s.

    bench/daemon_bench.py [--build build/release] [--live-seconds 30]

1. Live rate: the six roller recordings joined into one session (1 kHz per channel: roller and
   wheel encoders, pressure, tester force, test state) replayed in real time (speed 1, the same
   pacing a live bus has). CPU = (utime + stime) / wall time from /proc; memory = VmHWM.
2. Latency: the session four times over at speed 4 (24 events); p50/p99/max from the daemon's
   stats file (frame that closed the event received -> registers updated in the server thread,
   which includes the four fits and the fsync'd SQLite commit).
3. Modbus TCP: requests/s reading the 69-register event block with 1 client (reference, same
   run) and with 8 clients.
Prints a table and a brakefit.daemon_bench/1 JSON document.
"""
import argparse
import json
import os
import socket
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tests", "daemon"))
from logtools import concat, read_log, read_text, write_log  # noqa: E402

REC = os.path.join(ROOT, "data", "recorded")
TICK = os.sysconf("SC_CLK_TCK")


def log(msg):
    print(f"[daemon_bench] {msg}", file=sys.stderr, flush=True)


def free_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    p = s.getsockname()[1]
    s.close()
    return p


def brakefitd_version(build):
    out = subprocess.run([os.path.join(build, "daemon", "brakefitd"), "--version"],
                         capture_output=True, text=True)
    return out.stdout.split()[-1]


def cpu_s(pid):
    f = read_text(f"/proc/{pid}/stat").rsplit(")", 1)[1].split()
    return (int(f[11]) + int(f[12])) / TICK


def vm_hwm_kib(pid):
    for line in read_text(f"/proc/{pid}/status").splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1])
    return 0


class Run:
    def __init__(self, build, tmp, logfile, speed, name, extra_source="", extra_store="",
                 store=None, stderr=subprocess.DEVNULL):
        self.port = free_port()
        self.stats = os.path.join(tmp, f"{name}.stats.json")
        cfg = os.path.join(tmp, f"{name}.toml")
        bench = read_text(os.path.join(REC, "roller_2p2bar_fast.bench.toml"))
        with open(cfg, "w") as f:
            f.write(f'[daemon]\nmodel = "{ROOT}/data/models/default.json"\nstats_file = "{self.stats}"\n'
                    f'[source]\nkind = "replay"\nfile = "{logfile}"\nspeed = {speed}\n{extra_source}{bench}\n'
                    f'[modbus_tcp]\naddress = "127.0.0.1"\nport = {self.port}\n'
                    f'[store]\npath = "{store or os.path.join(tmp, name + ".db")}"\nmin_free_mb = 0\n{extra_store}')
        self.probe = os.path.join(build, "tests", "modbus_probe")
        self.proc = subprocess.Popen([os.path.join(build, "daemon", "brakefitd"), "-c", cfg],
                                     stderr=stderr)
        for _ in range(200):
            try:
                socket.create_connection(("127.0.0.1", self.port), 0.2).close()
                break
            except OSError:
                time.sleep(0.05)

    def registers(self):
        out = subprocess.run([self.probe, "--port", str(self.port), "read"], capture_output=True,
                             text=True, check=True)
        return json.loads(out.stdout)["registers"]

    def wait_finished(self, timeout):
        end = time.time() + timeout
        while time.time() < end:
            r = self.registers()
            if r["status_flags"] & 2:
                return r
            log(f"  {r['frames']} frames, {r['events_finished']} events")
            time.sleep(5)
        raise RuntimeError("replay did not finish")

    def load(self, clients, seconds):
        out = subprocess.run([self.probe, "--port", str(self.port), "load", "--clients",
                              str(clients), "--seconds", str(seconds)], capture_output=True,
                             text=True, check=True)
        return json.loads(out.stdout)

    def stop(self):
        self.proc.terminate()
        self.proc.wait(timeout=20)
        return json.loads(read_text(self.stats))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default=os.path.join(ROOT, "build", "release"))
    args = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="bf_bench_")
    names = [f"roller_{p}_{s}.log" for p in ("1p0bar", "2p2bar") for s in ("slow", "medium", "fast")]
    session = concat([read_log(os.path.join(REC, n)) for n in names])
    live_log = os.path.join(tmp, "session.log")
    write_log(live_log, session)
    span_s = (session[-1][0] - session[0][0]) / 1e6
    log(f"live-rate run: {len(session)} frames over {span_s:.1f} s ({len(session) / span_s:.0f} frames/s)")

    run = Run(args.build, tmp, live_log, 1.0, "live")
    t0, c0 = time.time(), cpu_s(run.proc.pid)
    r = run.wait_finished(span_s + 60)
    wall, cpu = time.time() - t0, cpu_s(run.proc.pid) - c0
    hwm = vm_hwm_kib(run.proc.pid)
    log("Modbus load: 1 client (reference), then 8 clients")
    one = run.load(1, 3)
    eight = run.load(8, 3)
    live_stats = run.stop()

    many_log = os.path.join(tmp, "many.log")
    write_log(many_log, concat([read_log(os.path.join(REC, n)) for n in names * 4]))
    log("latency run: 24 events at speed 4")
    run = Run(args.build, tmp, many_log, 4.0, "many")
    run.wait_finished(span_s + 60)
    lat = run.stop()["publish_latency_us"]

    doc = {
        "schema": "brakefit.daemon_bench/1",
        "version": live_stats["version"],
        "live": {"frames": r["frames"], "events": r["events_finished"], "wall_s": wall,
                 "frames_per_s": r["frames"] / wall, "cpu_s": cpu,
                 "cpu_pct_of_one_core": 100 * cpu / wall, "max_rss_kib": hwm,
                 "publish_latency_us": live_stats["publish_latency_us"]},
        "latency_24_events_us": lat,
        "modbus": {"clients_1_requests_per_s": one["requests_per_s"],
                   "clients_8_requests_per_s": eight["requests_per_s"],
                   "ratio_8_to_1": eight["requests_per_s"] / one["requests_per_s"],
                   "failed": one["failed"] + eight["failed"]},
    }
    print(f"live rate  : {doc['live']['frames_per_s']:.0f} frames/s, CPU {doc['live']['cpu_pct_of_one_core']:.2f} % "
          f"of one core (target < 2 %), max RSS {hwm / 1024:.1f} MiB, {r['events_finished']} events")
    print(f"latency    : event end -> registers p50 {lat['p50'] / 1000:.2f} ms, p99 {lat['p99'] / 1000:.2f} ms, "
          f"max {lat['max'] / 1000:.2f} ms over {lat['n']} events (target p99 < 20 ms)")
    print(f"modbus tcp : 1 client {one['requests_per_s']:.0f} req/s, 8 clients {eight['requests_per_s']:.0f} req/s "
          f"({doc['modbus']['ratio_8_to_1']:.2f}x), {doc['modbus']['failed']} failed")
    print(json.dumps(doc))


if __name__ == "__main__":
    main()
