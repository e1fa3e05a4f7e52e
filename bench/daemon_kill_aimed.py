#!/usr/bin/env python3
"""brakefitd killed -9 at aimed moments after an event closes: 0, 0.5, 1, 2, 3 and 5 ms after its
"event N closed" line (written once the event is in its journal file), 20 kills each by default,
all on one store; then one start on a log without events commits what the kills left.

    bench/daemon_kill_aimed.py [--build build/release] [--per-offset 20] [--seed 1]

Every run replays three roller events at speed 4; the bench tails the daemon's stderr and kills
it the chosen time after the first "closed" line. Counted: events that closed (their lines),
events stored after the recovery (rows), rows sharing a uid (stored twice), spill files left,
`PRAGMA integrity_check`, and the journal write's time from the lines themselves. Prints a table
and a brakefit.daemon_kill_aimed/1 JSON document.
"""
import argparse
import json
import os
import random
import re
import sqlite3
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tests", "daemon"))
sys.path.insert(0, os.path.join(ROOT, "bench"))
from daemon_bench import Run, brakefitd_version, log  # noqa: E402
from logtools import concat, read_log, write_log  # noqa: E402

REC = os.path.join(ROOT, "data", "recorded")
CLOSED = re.compile(rb"^info event \d+ closed \([a-z_]+\): journaled to \S+ in ([0-9.]+) ms", re.M)
OFFSETS_MS = (0.0, 0.5, 1.0, 2.0, 3.0, 5.0)


def kill_after_close(build, tmp, logfile, db, name, offset_s):
    err = os.path.join(tmp, f"{name}.log")
    with open(err, "wb") as ef:
        run = Run(build, tmp, logfile, 4.0, name, store=db, stderr=ef)
    buf, end = b"", time.time() + 60
    with open(err, "rb") as f:
        while time.time() < end and not CLOSED.search(buf):
            buf += f.read()
            time.sleep(0.0001)
    t_seen = time.perf_counter()
    while time.perf_counter() - t_seen < offset_s:
        pass  # a busy wait: sleep() overshoots sub-millisecond offsets
    run.proc.kill()
    run.proc.wait()
    with open(err, "rb") as f:
        text = f.read()
    return [float(m) for m in CLOSED.findall(text)]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default=os.path.join(ROOT, "build", "release"))
    ap.add_argument("--per-offset", type=int, default=20)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="bf_aimed_")
    three = os.path.join(tmp, "three.log")
    write_log(three, concat([read_log(os.path.join(REC, f"roller_2p2bar_{s}.log"))
                             for s in ("fast", "medium", "slow")]))
    quiet = os.path.join(tmp, "quiet.log")
    with open(quiet, "w") as f:
        f.write("(1700000000.000000) can0 7FF#00\n(1700000000.100000) can0 7FF#00\n")
    db = os.path.join(tmp, "events.db")
    plan = [o for o in OFFSETS_MS for _ in range(args.per_offset)]
    random.Random(args.seed).shuffle(plan)
    closed, journal_ms, per_offset = 0, [], {o: 0 for o in OFFSETS_MS}
    for k, off in enumerate(plan):
        ms = kill_after_close(args.build, tmp, three, db, f"k{k}", off / 1000)
        closed += len(ms)
        per_offset[off] += len(ms)
        journal_ms += ms
        if (k + 1) % 20 == 0:
            log(f"{k + 1}/{len(plan)} kills, {closed} events closed so far")
    err = os.path.join(tmp, "recover.log")
    with open(err, "wb") as ef:
        rec = Run(args.build, tmp, quiet, 0.0, "recover", store=db, stderr=ef,
                  extra_source="exit_at_end = true\n")
    rc = rec.proc.wait(timeout=600)
    con = sqlite3.connect(db)
    rows = con.execute("SELECT COUNT(*) FROM events").fetchone()[0]
    distinct = con.execute("SELECT COUNT(DISTINCT uid) FROM events").fetchone()[0]
    integrity = con.execute("PRAGMA integrity_check").fetchone()[0]
    con.close()
    left = [f for f in os.listdir(db + ".spill") if f.endswith(".cbor")]
    journal_ms.sort()
    q = lambda p: journal_ms[min(len(journal_ms) - 1, int(p * len(journal_ms)))] if journal_ms else float("nan")  # noqa: E731
    version = brakefitd_version(args.build)
    doc = {"schema": "brakefit.daemon_kill_aimed/1", "version": version, "seed": args.seed,
           "kills": len(plan), "offsets_ms": list(OFFSETS_MS), "closed": closed, "stored": rows,
           "lost": max(0, closed - rows), "duplicated": rows - distinct, "spill_files_left": len(left),
           "integrity": integrity, "recovery_exit": rc,
           "journal_write_ms": {"p50": q(0.5), "p99": q(0.99), "max": journal_ms[-1] if journal_ms else None}}
    print(f"kills      : {len(plan)} ({args.per_offset} at each of {', '.join(f'{o:g}' for o in OFFSETS_MS)} ms after 'closed')")
    print(f"closed     : {closed} events ({', '.join(f'{o:g} ms: {n}' for o, n in per_offset.items())})")
    print(f"stored     : {rows} after the recovery start (exit {rc}); lost {doc['lost']}, "
          f"stored twice {doc['duplicated']} (target 0, 0)")
    print(f"left       : {len(left)} spill files; integrity {integrity}")
    print(f"journal    : written in p50 {q(0.5):.2f} ms, p99 {q(0.99):.2f} ms after the close")
    print(json.dumps(doc))


if __name__ == "__main__":
    main()
