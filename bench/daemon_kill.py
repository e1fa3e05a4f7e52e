#!/usr/bin/env python3
"""brakefitd killed with SIGKILL at random points, N times on one store: nothing published is
missing from the store, the store stays consistent, and finished events are not lost.

    bench/daemon_kill.py [--build build/release] [--kills 50] [--seed 1]

Each round starts brakefitd on the same store with three roller events replayed at speed 4,
polls the last-event block every 20 ms, and kills it -9 at a uniformly random time in 0.1-4 s
(before, during and after events, fits and commits). After each kill: `PRAGMA integrity_check`;
every event id the registers showed is a stored row; events the daemon logged as finished
("event N (...)", written when the pipeline closes an event, before its commit) against rows added
(plus spill files, committed by the next start). Prints per-kill lines, the totals and a
brakefit.daemon_kill/1 JSON document.
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
from logtools import concat, read_log, read_text, write_log  # noqa: E402

REC = os.path.join(ROOT, "data", "recorded")


def rows(db):
    if not os.path.exists(db):
        return 0, "ok"
    con = sqlite3.connect(db)
    try:
        n = con.execute("SELECT COUNT(*) FROM events").fetchone()[0]
        ok = con.execute("PRAGMA integrity_check").fetchone()[0]
    finally:
        con.close()
    return n, ok


def ids(db):
    con = sqlite3.connect(db)
    try:
        return {r[0] for r in con.execute("SELECT id FROM events")}
    finally:
        con.close()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default=os.path.join(ROOT, "build", "release"))
    ap.add_argument("--kills", type=int, default=50)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    rng = random.Random(args.seed)
    tmp = tempfile.mkdtemp(prefix="bf_kill_")
    path = os.path.join(tmp, "three.log")
    write_log(path, concat([read_log(os.path.join(REC, f"roller_2p2bar_{s}.log"))
                            for s in ("fast", "medium", "slow")]))
    db = os.path.join(tmp, "events.db")
    spill = db + ".spill"
    totals = {"kills": 0, "finished": 0, "stored": 0, "published": 0, "published_missing": 0,
              "integrity_failures": 0, "lost": 0, "killed_during_event": 0}
    for k in range(args.kills):
        before, _ = rows(db)
        spilled_before = len(os.listdir(spill)) if os.path.isdir(spill) else 0
        err = os.path.join(tmp, f"kill{k}.log")
        with open(err, "w") as ef:
            run = Run(args.build, tmp, path, 4.0, f"k{k}", store=db, stderr=ef)
        t_kill = rng.uniform(0.1, 4.0)
        t0, shown, active = time.time(), set(), False
        while time.time() - t0 < t_kill:
            try:
                r = run.registers()
                if r["event.id"]:
                    shown.add(r["event.id"])
                active = bool(r["status_flags"] & (1 << 5))
            except Exception:  # noqa: BLE001 - the probe may race the start
                pass
            time.sleep(0.02)
        run.proc.kill()
        run.proc.wait()
        after, ok = rows(db)
        spilled = len(os.listdir(spill)) if os.path.isdir(spill) else 0
        text = read_text(err)
        finished = len(re.findall(r"^info event \d+ \(", text, re.M))
        adopted = len(re.findall(r"(\d+) event\(s\) spilled by an earlier run", text))
        stored_now = ids(db) if after else set()
        missing = len([i for i in shown if i not in stored_now])
        # This run's finished events are its new rows, minus the spilled ones it committed first,
        # plus what it spilled.
        new_rows = after - before
        from_spill = min(spilled_before, new_rows) if adopted else 0
        lost = max(0, finished - (new_rows - from_spill) - (spilled - (spilled_before - from_spill)))
        totals["kills"] += 1
        totals["finished"] += finished
        totals["stored"] += new_rows - from_spill
        totals["published"] += len(shown)
        totals["published_missing"] += missing
        totals["integrity_failures"] += ok != "ok"
        totals["lost"] += lost
        totals["killed_during_event"] += active
        log(f"kill {k + 1:2d} at {t_kill:4.2f} s{' (event running)' if active else ''}: "
            f"{finished} finished, {new_rows} rows added, {len(shown)} shown, {missing} shown but "
            f"not stored, {spilled} spilled, integrity {ok}, lost {lost}")
    version = brakefitd_version(args.build)
    doc = {"schema": "brakefit.daemon_kill/1", "version": version, "seed": args.seed, **totals}
    print(f"kills      : {totals['kills']} ({totals['killed_during_event']} during an event)")
    print(f"published  : {totals['published']} event ids shown, {totals['published_missing']} not in the store "
          f"(target 0)")
    print(f"finished   : {totals['finished']} events closed before a kill, {totals['lost']} lost (target 0)")
    print(f"integrity  : {totals['integrity_failures']} failed checks (target 0)")
    print(json.dumps(doc))


if __name__ == "__main__":
    main()
