#!/usr/bin/env python3
"""How `brakefit gap` scales with the number of runs in a set.

    bench/gap_many_runs.py [--build build/release] [--sets 3,6,12,24,48]
        [--results docs/gap_results.md] [--dry-run]

The three shipped 2.2 bar roller recordings (slow, medium, fast ramps) copied k times over give
sets of 3k runs; each set is diagnosed once and timed (wall clock). The 3-run set is the
reference measured in the same run: each larger set's time is reported as a ratio to it, next to
the ratio `brakefit gap` announces in advance (gap::relative_cost). The target: 24 runs within
10x the time of 3. Prints a table and a brakefit.gap_many_runs/1 JSON document; with --results,
writes the table into that file between its `gap_many_runs` markers, the command and the commit
at its head.
"""
import argparse
import datetime
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import time

from results_block import source_commit, writable, write_block

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REC = os.path.join(ROOT, "data", "recorded")
RAMPS = ("slow", "medium", "fast")


def log(msg):
    print(f"[gap_many_runs] {msg}", file=sys.stderr, flush=True)


def make_set(directory, copies):
    files = []
    for k in range(copies):
        for ramp in RAMPS:
            stem = f"roller_2p2bar_{ramp}"
            name = f"c{k:03d}_{stem}"
            shutil.copy(os.path.join(REC, stem + ".log"), os.path.join(directory, name + ".log"))
            shutil.copy(os.path.join(REC, stem + ".bench.toml"),
                        os.path.join(directory, name + ".bench.toml"))
            files.append(os.path.join(directory, name + ".log"))
    return files


def diagnose(brakefit, files):
    t0 = time.monotonic()
    p = subprocess.run([brakefit, "gap", "--json", *files], capture_output=True, text=True)
    wall = time.monotonic() - t0
    if p.returncode != 0:
        sys.exit(f"brakefit gap failed ({p.returncode}): {p.stderr[-2000:]}")
    m = re.search(r"expect about (\d+)x", p.stderr)
    doc = json.loads(p.stdout)
    return wall, (float(m.group(1)) if m else None), doc.get("verdict")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build", "release"))
    ap.add_argument("--sets", default="3,6,12,24,48")
    ap.add_argument("--results", help="markdown file to write the table into")
    ap.add_argument("--dry-run", action="store_true",
                    help="check the options and what they name, print the plan, run nothing")
    a = ap.parse_args()
    brakefit = os.path.join(a.build, "cli", "brakefit")
    try:
        sizes = [int(x) for x in a.sets.split(",")]
    except ValueError:
        ap.error(f"--sets takes run counts separated by commas, not {a.sets!r}")
    if any(n < 1 for n in sizes):
        ap.error(f"--sets takes run counts of 1 or more, not {a.sets!r}")
    if not os.access(brakefit, os.X_OK):
        sys.exit(f"gap_many_runs: {brakefit} is not built (--build)")
    if a.results and not writable(a.results):
        sys.exit(f"gap_many_runs: cannot write the results file {a.results}")
    if 3 not in sizes:
        sizes.insert(0, 3)
    if a.dry_run:
        print(json.dumps({"schema": "brakefit.gap_many_runs_plan/1", "version": 1,
                          "runs": [3 * max(1, n // 3) for n in sizes], "results": a.results}))
        return
    start = time.time()
    commit = source_commit(ROOT)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for n in sizes:
            d = os.path.join(tmp, f"set{n}")
            os.makedirs(d)
            files = make_set(d, max(1, n // 3))
            log(f"{len(files)} runs ...")
            wall, announced, verdict = diagnose(brakefit, files)
            rows.append({"runs": len(files), "wall_s": round(wall, 2), "announced_ratio": announced,
                         "verdict": verdict})
    ref = next(r["wall_s"] for r in rows if r["runs"] == 3)
    lines = [f"{'runs':>5} {'wall s':>8} {'x 3 runs':>9} {'announced':>10}  verdict"]
    for r in rows:
        r["ratio_to_3"] = round(r["wall_s"] / ref, 2)
        ann = "-" if r["announced_ratio"] is None else f"{r['announced_ratio']:.0f}x"
        lines.append(f"{r['runs']:>5} {r['wall_s']:>8.2f} {r['ratio_to_3']:>8.2f}x {ann:>10}  "
                     f"{', '.join(r['verdict'] or [])}")
    target = next((r for r in rows if r["runs"] == 24), None)
    if target:
        lines.append(f"24 runs: {target['ratio_to_3']:.1f}x the time of 3 (target <= 10x): "
                     f"{'met' if target['ratio_to_3'] <= 10 else 'MISSED'}")
    command = shlex.join(["python3", "bench/gap_many_runs.py"] + sys.argv[1:])
    head = (f"<!-- written by `{command}` at commit {commit} ({datetime.date.today()}, "
            f"{(time.time() - start) / 60:.0f} min) -->")
    print(head)
    print("\n".join(lines))
    print(json.dumps({"schema": "brakefit.gap_many_runs", "version": 1, "commit": commit,
                      "rows": rows}))
    if a.results:
        write_block(a.results, "gap_many_runs", head + "\n\n```\n" + "\n".join(lines) + "\n```")
        log(f"wrote the table into {a.results}")


if __name__ == "__main__":
    main()
