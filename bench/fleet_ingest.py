#!/usr/bin/env python3
"""bench/fleet_ingest.py: the fleet path's throughput on this machine (a benchmark, not a test).
The stations' syncs run on the same two cores as the server here, so besides the wall-clock rate
the server's own CPU per event is measured (its postmaster and reaped backends): two cores divided
by it is what the server takes when the stations are elsewhere, as they are.

  sudo BRAKEFIT_BIN=build/release/cli/brakefit BRAKEFITD_BIN=build/release/daemon/brakefitd \
      python3 bench/fleet_ingest.py [--stations 100] [--events 1000] [--report-events 1000000]

Starts a PostgreSQL 15 of its own (tests/fleet/pgserver.py: TLS on, fsync off as in the tests),
gives each station a store of `--events` events (a real brakefitd replay, its rows cloned with new
uids) and runs `brakefit-sync --once` (the service's binary: `brakefit sync` without the fitting
libraries) for all stations, `--parallel` at a time, measuring:
  - ingest: events per second into the one server (target >= 5000/s on 2 cores);
  - a station's CPU: sync's CPU seconds per event shipped, and an idle sync's CPU share over 10 s
    (the station's steady state; target < 1 % of a core);
  - the report: `brakefit fleet report` over `--report-events` rows (target < 10 s), rows
    generated on the server across 100 lanes and 26 weeks.
Prints a markdown table with the command and the commit at its head."""
import argparse
import os
import resource
import shutil
import sqlite3
import subprocess
import sys
import tempfile
import time
import uuid

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tests", "fleet"))
os.environ.setdefault("BRAKEFIT_ROOT", ROOT)
os.environ.setdefault("BRAKEFIT_BIN", os.path.join(ROOT, "build/release/cli/brakefit"))
os.environ.setdefault("BRAKEFITD_BIN", os.path.join(ROOT, "build/release/daemon/brakefitd"))
import pgserver  # noqa: E402
import fleet_harness as tf  # noqa: E402  (the stores are made as the tests make them)

CLI = os.environ["BRAKEFIT_BIN"]
SYNC = CLI + "-sync"  # brakefit-sync, beside brakefit in the build tree


def server_cpu(server):
    """The server's CPU seconds: the postmaster's own and its reaped backends' (cutime, cstime)."""
    with open(os.path.join(server.data, "postmaster.pid")) as f:
        pid = int(f.readline())
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    # After the ")" the fields start at state (field 3): utime is field 14, cstime field 17.
    return sum(int(x) for x in fields[11:15]) / os.sysconf("SC_CLK_TCK")


def children_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--stations", type=int, default=100)
    ap.add_argument("--events", type=int, default=1000)
    ap.add_argument("--report-events", type=int, default=1_000_000)
    ap.add_argument("--parallel", type=int, default=8)
    a = ap.parse_args()
    why = pgserver.available()
    if why:
        sys.exit(f"fleet_ingest: {why}")
    server = pgserver.PgServer()
    tf.SERVER = server
    tf.TMP = tempfile.mkdtemp(prefix="brakefit-ingest-")
    try:
        r = tf.run_cli("fleet", "init", server.admin_url())
        assert r.returncode == 0, r.stderr
        template = os.path.join(tf.TMP, "template.db")
        tf.replay_into(template, ["roller_2p2bar_fast.log"])
        tf.age_rows(template, 30 * 86400)
        stations = []
        for i in range(a.stations):
            name = f"st{i:03d}"
            tf.STATIONS[name] = f"station_{name}"
            pw = tf.write(f"station_{name}.pw", f"pw-{i}\n")
            r = tf.run_cli("fleet", "add-station", server.admin_url(), "--station", name, "--role",
                           f"station_{name}", "--station-password-file", pw)
            assert r.returncode == 0, r.stderr
            st = tf.Station(name)
            shutil.copy(template, st.store)
            db = sqlite3.connect(st.store)  # a station's own event: its own uid
            db.execute("UPDATE events SET uid = ?", (uuid.uuid4().hex,))
            db.commit()
            db.close()
            tf.clone_rows(st.store, a.events - 1, step_s=60)
            stations.append(st)
        print(f"{a.stations} stores of {a.events} events ready", file=sys.stderr)
        cpu0, t0, srv0 = children_cpu(), time.time(), server_cpu(server)
        running = []
        for st in stations:
            running.append(subprocess.Popen([SYNC, *st.args(extra=("--once", "--batch", "500"))[1:]],
                                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE))
            while len([p for p in running if p.poll() is None]) >= a.parallel:
                time.sleep(0.01)
        for p in running:
            assert p.wait() == 0, p.stderr.read()
        wall, cpu = time.time() - t0, children_cpu() - cpu0
        time.sleep(1)  # the last backends exit and are reaped
        srv = server_cpu(server) - srv0
        total = int(server.psql("SELECT count(*) FROM brakefit.events"))
        assert total == a.stations * a.events, total
        # An idle sync (everything shipped): its CPU share over 10 s.
        idle = subprocess.Popen([SYNC, *stations[0].args()[1:]], stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)
        time.sleep(2)
        with open(f"/proc/{idle.pid}/stat") as f:
            f0 = f.read().split()
        time.sleep(10)
        with open(f"/proc/{idle.pid}/stat") as f:
            f1 = f.read().split()
        idle.terminate()
        idle.wait()
        tick = os.sysconf("SC_CLK_TCK")
        idle_share = ((int(f1[13]) + int(f1[14])) - (int(f0[13]) + int(f0[14]))) / tick / 10.0
        # The report over report_events rows (generated on the server: 100 lanes, 26 weeks).
        server.psql("SELECT brakefit.ensure_month(now() - make_interval(days => d)) "
                    "FROM generate_series(0, 190, 20) d")
        server.psql(
            "INSERT INTO brakefit.events (station_id, lane_id, event_uid, created_at, store_row_id, "
            "source, vehicle_id, bench, end_reason, flags, points, model_hash, calibration_toml, "
            "result, wheel_load_n, peak_friction, slip_stiffness_n, fit_method) "
            f"SELECT 'gen' || (g % 50), (g % 2)::text, 'gen-' || g, now() - make_interval(secs => "
            f"(g % 15724800)), g, 'bench', '', 'roller', 'switch_off', '', 500, 'sha256:gen', '', "
            f"'{{}}', 3800, 0.9 + 0.05 * random(), 3800 * (20 + random()), 'hybrid' "
            f"FROM generate_series(1, {a.report_events}) g")
        server.psql("ANALYZE brakefit.events")
        rows = int(server.psql("SELECT count(*) FROM brakefit.events"))
        t1 = time.time()
        r = tf.run_cli("fleet", "report", server.admin_url(), "--json", timeout=600)
        report_s = time.time() - t1
        assert r.returncode == 0, r.stderr
        commit = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"],
                                capture_output=True, text=True).stdout.strip()
        rate = total / wall
        print(f"<!-- written by `python3 bench/fleet_ingest.py --stations {a.stations} --events "
              f"{a.events} --report-events {a.report_events} --parallel {a.parallel}` at commit "
              f"{commit} -->\n")
        print("| figure | measured | target |\n|---|---|---|")
        print(f"| ingest, {a.stations} stations x {a.events} events, {a.parallel} syncs at a time | "
              f"{rate:.0f} events/s ({total} in {wall:.1f} s) | >= 5000 events/s |")
        print(f"| the server's CPU per event taken | {1000 * srv / total:.3f} ms: {total / srv:.0f} "
              f"events/s a core, {2 * total / srv:.0f} events/s on two with the stations "
              f"elsewhere | >= 5000 events/s |")
        print(f"| a station's sync, CPU per event shipped | {1000 * cpu / total:.3f} ms | |")
        print(f"| a station at 1 event a minute: shipping CPU | {100 * cpu / total / 60:.4f} % of "
              f"a core | < 1 % |")
        print(f"| an idle sync (polls its store every second) | {100 * idle_share:.3f} % of a core "
              f"| < 1 % |")
        print(f"| `fleet report` over {rows} events | {report_s:.2f} s | < 10 s |")
    finally:
        server.close()
        shutil.rmtree(tf.TMP, ignore_errors=True)


if __name__ == "__main__":
    main()
