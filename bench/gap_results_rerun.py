#!/usr/bin/env python3
"""Rerun the blocks of the gap diagnosis's results file, each by the command at its head.

    /usr/bin/python3 bench/gap_results_rerun.py [--results docs/gap_results.md]
        [--match REGEX] [--list | --dry-run] [--build DIR] [--gen-c SCRIPT]

Every measured table in docs/gap_results.md sits in a block (`<!-- KEY begin -->` to
`<!-- KEY end -->`) whose first line is `<!-- written by `COMMAND` at commit C (DATE, N min) -->`:
the bench that wrote it (bench/gap_referee, bench/gap_c_suite.py, bench/gap_many_runs.py), which
writes the block again when it is run. This runs those commands from the source tree's root, in
the file's order, one at a time (each takes the machine's cores): all of them, or the blocks whose
key matches --match (e.g. 'ground|gap_c_suite' after a change to the ground's diagnosis).

  --list     each block's key, commit, date and minutes, and the minutes they took in all
  --dry-run  each command checked as its bench reads it (the referee's --dry-run 1, the scripts'
             --dry-run): options, scripts and binaries it names, the results file; nothing run.
             Fails, naming the block, on a command its bench refuses or a head that is missing.
  --build    run the benches of another build: a referee command's build/release/ prefix and
             the scripts' --build become DIR (the commands written at the heads say so).
  --gen-c    generator C's script for the commands that run it.

A bench's block head records the commit of the tree it ran in: rerun in a tree whose code is
committed (a worktree of that commit keeps the checkout one works in free).
"""
import argparse
import os
import re
import shlex
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BLOCK = re.compile(r"<!-- (?P<key>[^\n]*?) begin -->\n(?P<body>.*?)<!-- (?P=key) end -->", re.S)
HEAD = re.compile(r"<!-- written by `(?P<cmd>.*?)` at commit (?P<commit>\S+) "
                  r"\((?P<date>\d{4}-\d\d-\d\d), (?P<min>\d+) min")
REFEREE_PREFIX = "build/release/"


def log(msg):
    print(f"[gap_results_rerun] {msg}", file=sys.stderr, flush=True)


def blocks(text, path):
    """(key, head match) of every block in the file; a block without a head is an error."""
    out = []
    for b in BLOCK.finditer(text):
        head = HEAD.search(b.group("body"))
        line = text.count("\n", 0, b.start()) + 1
        if not head:
            raise SystemExit(f"{path}:{line}: block '{b.group('key')}' has no `written by` head")
        out.append((b.group("key"), head, line))
    loose = len(HEAD.findall(text)) - len(out)
    if loose:
        raise SystemExit(f"{path}: {loose} `written by` head(s) outside a begin/end block: "
                         "a table no bench can write again")
    return out


def option(argv, name, default=None):
    return argv[argv.index(name) + 1] if name in argv[:-1] else default


def runs_c(argv, referee):
    if referee:
        return "C" in option(argv, "--generators", "A,B")
    return any(a.endswith("gap_c_suite.py") for a in argv[:2])


def command(cmd, build, gen_c, dry_run):
    """The argv a block's command runs as, with --build, --gen-c and --dry-run applied."""
    argv = shlex.split(cmd)
    referee = argv[0].endswith("/gap_referee")
    if gen_c and runs_c(argv, referee):
        if "--gen-c" in argv[:-1]:
            argv[argv.index("--gen-c") + 1] = gen_c
        else:
            argv += ["--gen-c", gen_c]
    if build and referee and argv[0].startswith(REFEREE_PREFIX):
        argv[0] = os.path.join(build, argv[0][len(REFEREE_PREFIX):])
    if build and not referee and "--build" not in argv:
        argv += ["--build", build]
    if dry_run:
        argv += ["--dry-run", "1"] if referee else ["--dry-run"]
    return argv


def writes(argv):
    """(results file, block key) that a bench's command writes: its block is rewritten only
    where these are the block's own."""
    bench = os.path.basename(argv[1] if argv[0].endswith("python3") and len(argv) > 1 else argv[0])
    results, key = option(argv, "--results"), option(argv, "--results-key", "")
    if bench == "gap_referee":
        return results, "gap_referee " + (key or f"{option(argv, '--condition', 'all')} "
                                                 f"{option(argv, '--generators', 'A,B')}")
    if bench == "gap_c_suite.py":
        return results, "gap_c_suite" + (f" {key}" if key else "")
    return results, bench.removesuffix(".py")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--results", default=os.path.join(ROOT, "docs", "gap_results.md"))
    ap.add_argument("--match", default="", help="only the blocks whose key matches this regex")
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--list", action="store_true")
    mode.add_argument("--dry-run", action="store_true")
    ap.add_argument("--build", help="the build whose benches run (default: as each head says)")
    ap.add_argument("--gen-c", help="generator C's script for the commands that run it "
                                    "(default: as each says, ../shared/gapgen/gen_c.py)")
    a = ap.parse_args()
    try:
        match = re.compile(a.match)
    except re.error as e:
        ap.error(f"--match is not a regular expression: {e}")
    with open(a.results) as f:
        found = [b for b in blocks(f.read(), a.results) if match.search(b[0])]
    if not found:
        sys.exit(f"gap_results_rerun: no block of {a.results} matches '{a.match}'")
    if a.list:
        for key, head, line in found:
            print(f"{line:>5}  {head.group('commit'):<8} {head.group('date')} "
                  f"{int(head.group('min')):>4} min  {key}")
        print(f"{len(found)} blocks, {sum(int(h.group('min')) for _, h, _ in found)} min as last run")
        return
    # Every block's command is checked to write its own block before any runs (a rerun of all
    # of them takes hours).
    plan, failed = [], []
    for key, head, line in found:
        argv = command(head.group("cmd"), a.build, a.gen_c, a.dry_run)
        results, writes_key = writes(argv)
        where = f"{a.results}:{line}: block '{key}'"
        if results is None or os.path.realpath(os.path.join(ROOT, results)) != \
                os.path.realpath(a.results) or writes_key != key:
            failed.append(f"{where}: its command writes {results or 'no results file'}, "
                          f"block '{writes_key}'")
        else:
            plan.append((key, head, where, argv))
    if a.dry_run:
        for key, head, where, argv in plan:
            p = subprocess.run(argv, cwd=ROOT, capture_output=True, text=True)
            if p.returncode != 0:
                why = (p.stderr.strip().splitlines() or ["(no message)"])[-1]
                failed.append(f"{where}: {shlex.join(argv)}: exit {p.returncode}: {why}")
    for f in failed:
        print(f, file=sys.stderr)
    if a.dry_run:
        print(f"{len(found) - len(failed)} of {len(found)} blocks' commands check")
    if failed:
        sys.exit(1)
    if a.dry_run:
        return
    for n, (key, head, where, argv) in enumerate(plan, 1):
        log(f"[{n}/{len(plan)}] {key}: last run at {head.group('commit')} took "
            f"{head.group('min')} min")
        t0 = time.monotonic()
        p = subprocess.run(argv, cwd=ROOT, stdout=subprocess.DEVNULL)
        if p.returncode != 0:
            sys.exit(f"gap_results_rerun: {where} failed (exit {p.returncode}): "
                     f"{shlex.join(argv)}")
        log(f"[{n}/{len(plan)}] {key}: {(time.monotonic() - t0) / 60:.0f} min")

if __name__ == "__main__":
    main()
