#!/usr/bin/env python3
"""brakefitd soak: RSS and open file descriptors while it runs for hours, with the growth per hour.

    bench/daemon_soak.py [--build build/release] [--seconds 7200] [--speed 1] [--sample-s 10]

The six roller recordings joined into one session are replayed in a loop (`source.loop`, stamps
shifted each pass) at --speed (1: the live rate, for --seconds of wall time; 0: as fast as possible,
hours of data in minutes). Every --sample-s the daemon's VmRSS and the entries of /proc/PID/fd are
sampled, with the events stored so far; growth per hour is the least-squares slope over the second
half of the run (after the allocator and SQLite's page cache have warmed up), per hour of wall time
and per hour of data. Target: flat (RSS growth within noise, 0 fds per hour). Prints a table, and a
brakefit.daemon_soak/1 JSON document.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tests", "daemon"))
sys.path.insert(0, os.path.join(ROOT, "bench"))
from daemon_bench import Run, log  # noqa: E402
from logtools import concat, read_log, read_text, write_log  # noqa: E402

REC = os.path.join(ROOT, "data", "recorded")


def rss_kib(pid):
    for line in read_text(f"/proc/{pid}/status").splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    return 0


def slope_per_hour(xs_s, ys):
    n = len(xs_s)
    if n < 3:
        return float("nan")
    mx, my = sum(xs_s) / n, sum(ys) / n
    sxx = sum((x - mx) ** 2 for x in xs_s)
    return 3600.0 * sum((x - mx) * (y - my) for x, y in zip(xs_s, ys)) / sxx if sxx else float("nan")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default=os.path.join(ROOT, "build", "release"))
    ap.add_argument("--seconds", type=float, default=7200)
    ap.add_argument("--speed", type=float, default=1.0)
    ap.add_argument("--sample-s", type=float, default=10)
    args = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="bf_soak_")
    names = [f"roller_{p}_{s}.log" for p in ("1p0bar", "2p2bar") for s in ("slow", "medium", "fast")]
    session = concat([read_log(os.path.join(REC, n)) for n in names])
    path = os.path.join(tmp, "session.log")
    write_log(path, session)
    pass_s = (session[-1][0] - session[0][0]) / 1e6 + 1.0
    log(f"soak: {len(session)} frames a pass ({pass_s:.1f} s of data), speed {args.speed}, "
        f"{args.seconds:.0f} s")
    run = Run(args.build, tmp, path, args.speed, "soak", extra_source="loop = true\n")
    pid = run.proc.pid
    samples = []  # (wall s, data s, rss KiB, fds, events)
    t0 = time.time()
    while time.time() - t0 < args.seconds:
        time.sleep(min(args.sample_s, max(0.0, args.seconds - (time.time() - t0))))
        r = run.registers()
        wall = time.time() - t0
        data_s = r["frames"] / len(session) * pass_s
        samples.append((wall, data_s, rss_kib(pid), len(os.listdir(f"/proc/{pid}/fd")),
                        r["events_finished"]))
        w, d, rss, fds, ev = samples[-1]
        log(f"  {w:7.0f} s wall, {d / 3600:6.2f} h data: RSS {rss / 1024:7.1f} MiB, {fds} fds, "
            f"{ev} events")
    stats = run.stop()
    half = samples[len(samples) // 2:]
    wall_s = [s[0] for s in half]
    data_s = [s[1] for s in half]
    rss = [s[2] for s in half]
    fds = [s[3] for s in half]
    doc = {
        "schema": "brakefit.daemon_soak/1",
        "version": stats["version"],
        "speed": args.speed,
        "wall_s": samples[-1][0],
        "data_h": samples[-1][1] / 3600,
        "events": samples[-1][4],
        "samples": len(samples),
        "rss_kib": {"first": samples[0][2], "last": samples[-1][2], "max": max(s[2] for s in samples)},
        "fds": {"first": samples[0][3], "last": samples[-1][3], "max": max(s[3] for s in samples)},
        "second_half_growth": {
            "rss_kib_per_wall_h": slope_per_hour(wall_s, rss),
            "rss_kib_per_data_h": slope_per_hour(data_s, rss),
            "fds_per_wall_h": slope_per_hour(wall_s, fds),
            "fds_per_data_h": slope_per_hour(data_s, fds),
        },
    }
    g = doc["second_half_growth"]
    print(f"soak       : {doc['wall_s']:.0f} s wall, {doc['data_h']:.2f} h of data, {doc['events']} events")
    print(f"RSS        : {doc['rss_kib']['first'] / 1024:.1f} -> {doc['rss_kib']['last'] / 1024:.1f} MiB "
          f"(max {doc['rss_kib']['max'] / 1024:.1f}); second half {g['rss_kib_per_wall_h']:+.0f} KiB per wall h, "
          f"{g['rss_kib_per_data_h']:+.1f} KiB per data h")
    print(f"fds        : {doc['fds']['first']} -> {doc['fds']['last']} (max {doc['fds']['max']}); "
          f"second half {g['fds_per_wall_h']:+.2f} per wall h")
    print(json.dumps(doc))


if __name__ == "__main__":
    main()
