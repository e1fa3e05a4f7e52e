"""Recorded tests: simulate, replay, export, compare, candump compatibility with can-utils, the
README tour and fits at a bound (gap through the CLI: test_gap_cli.py)."""
import glob
import json
import os
import re
import shutil
import subprocess
import tempfile
import unittest

from test_cli import BIN, ROOT, run, svg_series, write

REC = os.path.join(ROOT, "data", "recorded")
SCEN = os.path.join(ROOT, "sim", "scenarios")


def recorded(pattern):
    """The shipped recordings matching a glob, in the order the shell expands them."""
    return sorted(glob.glob(os.path.join(REC, pattern)))


class Simulate(unittest.TestCase):
    def test_writes_log_calibration_and_truth(self):
        with tempfile.TemporaryDirectory() as d:
            out = os.path.join(d, "r.log")
            r = run("simulate", os.path.join(SCEN, "roller_car.toml"), "--ramp", "fast", "--out", out)
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertIn("ended by switch_off_slip", r.stdout)
            truth = json.load(open(os.path.join(d, "r.truth.json")))
            self.assertEqual(truth["schema"], "brakefit.truth/1")
            self.assertEqual(truth["ramp_bar_per_s"], 60.0)
            self.assertIn("roller_friction", truth["effects"])
            self.assertTrue(os.path.exists(os.path.join(d, "r.bench.toml")))
            with open(out) as f:
                first = f.readline()
            self.assertRegex(first, r"^\(\d{10}\.\d{6}\) can0 [0-9A-F]{3}#[0-9A-F]{16}$")

    def test_shipped_recordings_are_reproducible(self):
        with tempfile.TemporaryDirectory() as d:
            out = os.path.join(d, "x.log")
            # make.sh: roller at 2.2 bar, slow ramp, is the 7th recording (seed 107).
            r = run("simulate", os.path.join(SCEN, "roller_car.toml"), "--ramp", "slow", "--tyre-pressure", "2.2",
                    "--seed", "107", "--out", out)
            self.assertEqual(r.returncode, 0, r.stderr)
            with open(out) as a, open(os.path.join(REC, "roller_2p2bar_slow.log")) as b:
                self.assertEqual(a.read(), b.read())

    def test_bad_scenario_exits_78_naming_the_key(self):
        with tempfile.TemporaryDirectory() as d:
            sc = write(d, "s.toml", "[effects]\nroller_friction = 3.0\n")
            r = run("simulate", sc, "--out", os.path.join(d, "x.log"))
            self.assertEqual(r.returncode, 78)
            self.assertIn("key 'effects.roller_friction'", r.stderr)


class Replay(unittest.TestCase):
    def test_json_events_and_report(self):
        log = os.path.join(REC, "roller_1p0bar_medium.log")
        with tempfile.TemporaryDirectory() as d:
            r = run("replay", "--json", "--report", d, log)
            self.assertEqual(r.returncode, 0, r.stderr)
            docs = [json.loads(l) for l in r.stdout.splitlines()]
            self.assertEqual(len(docs), 1)
            doc = docs[0]
            for k in ("schema", "version", "model_hash", "event_id", "bench", "t_start_ns", "t_end_ns",
                      "end_reason", "flags", "points", "results"):
                self.assertIn(k, doc)
            self.assertEqual(doc["schema"], "brakefit.event/1")
            self.assertEqual(doc["bench"], "roller")
            self.assertEqual(doc["end_reason"], "switch_off_slip")
            self.assertEqual(doc["flags"], [])
            self.assertGreater(doc["t_end_ns"], doc["t_start_ns"])
            self.assertEqual([x["method"] for x in doc["results"]], ["som", "mlp", "lm", "hybrid"])
            hybrid = doc["results"][3]
            truth = json.load(open(log.replace(".log", ".truth.json")))["pac96_equivalent"]
            self.assertAlmostEqual(hybrid["D"] / truth["D"], 1.0, delta=0.15)  # effects on: bias expected
            _, series = svg_series(os.path.join(d, "roller_1p0bar_medium-event-1.svg"))
            self.assertEqual(series[0], "measured")
            self.assertEqual(len(series), 5)
            self.assertEqual(len(open(os.path.join(d, "events.jsonl")).read().splitlines()), 1)

    def test_tester_force_and_missing_calibration(self):
        with tempfile.TemporaryDirectory() as d:
            shutil.copy(os.path.join(REC, "roller_2p2bar_fast.log"), d)
            log = os.path.join(d, "roller_2p2bar_fast.log")
            r = run("replay", log)
            self.assertEqual(r.returncode, 65)
            self.assertIn("no bench calibration", r.stderr)
            r = run("replay", "--json", "--force", "tester", "--method", "lm", "--bench",
                    os.path.join(REC, "roller_2p2bar_fast.bench.toml"), log)
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertEqual(len(json.loads(r.stdout)["results"]), 1)

    def test_malformed_log_line_and_lenient(self):
        with tempfile.TemporaryDirectory() as d:
            with open(os.path.join(REC, "roller_2p2bar_fast.log")) as f:
                lines = f.readlines()
            lines.insert(5, "(1700000000.005000) can0 10#ZZ\n")
            log = write(d, "bad.log", "".join(lines))
            shutil.copy(os.path.join(REC, "roller_2p2bar_fast.bench.toml"), os.path.join(d, "bad.bench.toml"))
            r = run("replay", log)
            self.assertEqual(r.returncode, 65)
            self.assertIn(log + ":6:", r.stderr)
            r = run("replay", "--lenient", "--json", log)
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertIn("1 malformed lines skipped", r.stderr)
            self.assertEqual(json.loads(r.stdout)["end_reason"], "switch_off_slip")


class ExportAndCompare(unittest.TestCase):
    def test_export_then_replay_the_event_csv(self):
        with tempfile.TemporaryDirectory() as d:
            r = run("export", os.path.join(REC, "ground_2p2bar_150barps.log"), "--events", d)
            self.assertEqual(r.returncode, 0, r.stderr)
            csvs = glob.glob(os.path.join(d, "*.csv"))
            self.assertEqual(len(csvs), 1)
            text = open(csvs[0]).read()
            for key in ("bench=ground", "wheel_radius_m=", "wheel_load_n=", "brake_gain_n_per_bar=",
                        "tyre_pressure_bar=", "speed_kmh="):
                self.assertIn("# " + key, text)
            self.assertIn("t_s,v_ref_mps,v_wheel_mps,pressure_bar\n", text)
            a = json.loads(run("replay", "--json", "--method", "hybrid", csvs[0]).stdout)
            b = json.loads(run("replay", "--json", "--method", "hybrid",
                               os.path.join(REC, "ground_2p2bar_150barps.log")).stdout)
            self.assertEqual(a["points"], b["points"])
            self.assertAlmostEqual(a["results"][0]["D"], b["results"][0]["D"], delta=1e-3 * b["results"][0]["D"])

    def test_compare_roller_and_ground(self):
        with tempfile.TemporaryDirectory() as d:
            svg = os.path.join(d, "c.svg")
            r = run("compare", "--json", "--svg", svg, os.path.join(REC, "roller_1p0bar_slow.log"),
                    os.path.join(REC, "ground_1p0bar_100barps.log"))
            self.assertEqual(r.returncode, 0, r.stderr)
            doc = json.loads(r.stdout)
            self.assertEqual(doc["schema"], "brakefit.compare/1")
            for side in ("a", "b"):
                for k in ("B", "C", "D", "E", "uncertainty", "peak_force_n", "peak_slip_ratio", "events"):
                    self.assertIn(k, doc[side])
            self.assertGreater(doc["b"]["peak_force_n"], doc["a"]["peak_force_n"])
            root, series = svg_series(svg)
            # Measured points and the fit of each side; past a side's data its fit is dashed
            # ("beyond its data"): the roller stops at 27 % slip.
            self.assertEqual(len([n for n in series if "beyond its data" not in n]), 4, series)
            beyond = [g for g in root.iter("{http://www.w3.org/2000/svg}g")
                      if g.get("class") == "series" and "beyond its data" in g.get("data-name")]
            self.assertTrue(beyond, series)
            for g in beyond:
                self.assertIsNotNone(next(g.iter("{http://www.w3.org/2000/svg}polyline"))
                                     .get("stroke-dasharray"))
            texts = {t.get("class"): "".join(t.itertext()) for t in root.iter("{http://www.w3.org/2000/svg}text")
                     if t.get("class")}
            self.assertEqual(texts["x-label"], "slip [%]")
            self.assertEqual(texts["y-label"], "brake force [N]")

    def test_compare_several_runs_per_side_as_the_shell_expands_them(self):
        roller, road = recorded("roller_1p0bar_*.log"), recorded("ground_1p0bar_*.log")
        r = run("compare", "--json", "--roller", *roller, "--road", *road)
        self.assertEqual(r.returncode, 0, r.stderr)
        doc = json.loads(r.stdout)
        self.assertEqual(doc["a"]["files"], roller)
        self.assertEqual(doc["b"]["files"], road)
        self.assertEqual(doc["a"]["label"], "roller (3 runs)")
        self.assertEqual(doc["a"]["events"], 3)
        # The roller against an MF 6.1 file fitted to the road, as MF scaling factors.
        sc = doc["mf61_scaling"]
        self.assertEqual((sc["rig"], sc["reference"]), ("roller (3 runs)", "road (3 runs)"))
        factors = {f["name"]: f for f in sc["factors"]}
        self.assertEqual(list(factors), ["LMUX", "LKX", "LCX", "LEX"])
        self.assertEqual(factors["LMUX"]["status"], "fitted")
        self.assertGreater(factors["LMUX"]["stderr"], 0)
        for f in factors.values():
            self.assertEqual(f["status"] == "held", bool(f["reason"]), f)
        self.assertLess(sc["rms_pct_peak"], sc["unscaled_rms_pct_peak"])
        # The same runs as one directory per side give the same pooled fit.
        with tempfile.TemporaryDirectory() as d:
            for side, files in (("r", roller), ("g", road)):
                os.mkdir(os.path.join(d, side))
                for f in files:
                    for ext in (".log", ".bench.toml"):
                        shutil.copy(f[:-4] + ext, os.path.join(d, side))
            r2 = run("compare", "--json", os.path.join(d, "r"), os.path.join(d, "g"))
            self.assertEqual(r2.returncode, 0, r2.stderr)
            self.assertAlmostEqual(json.loads(r2.stdout)["a"]["D"], doc["a"]["D"], delta=1e-6)
        # Half of a pair, or both forms at once, is a usage error.
        for args in (("--roller", roller[0]),
                     (roller[0], road[0], "--roller", roller[1], "--road", road[1])):
            r = run("compare", *args)
            self.assertEqual(r.returncode, 64, r.stderr)
            self.assertIn("--roller RUNS... --road RUNS...", r.stderr)


@unittest.skipUnless(shutil.which("log2asc"), "can-utils' log2asc is not installed")
class CanUtilsCompatibility(unittest.TestCase):
    def test_log2asc_accepts_every_line_of_our_logs(self):
        log = os.path.join(REC, "roller_2p2bar_fast.log")
        r = subprocess.run(["log2asc", "-I", log, "can0"], capture_output=True, text=True, timeout=60)
        self.assertEqual(r.returncode, 0, r.stderr)
        frames = [l for l in r.stdout.splitlines() if " Rx " in l]
        with open(log) as f:
            self.assertEqual(len(frames), sum(1 for _ in f))
        # First frame: id 100, 8 data bytes, as written.
        self.assertRegex(frames[0], r"^\s+0\.000000 1\s+100\s+Rx\s+d 8 08 00 00 89 03 00 00 00$")

    def test_log2asc_reads_the_candump_L_fixture_we_replay(self):
        fixture = os.path.join(ROOT, "tests", "fixtures", "candump_L.log")
        r = subprocess.run(["log2asc", "-I", fixture, "can0", "can1", "vcan0"], capture_output=True, text=True,
                           timeout=60)
        self.assertEqual(r.returncode, 0, r.stderr)


class ReadmeTour(unittest.TestCase):
    """Every brakefit and brakefitd command of the README, as written, in order, from a clone's
    root with the binaries on PATH as it says (the station's own lines aside: /etc, the installed
    store)."""

    def test_every_readme_command_runs_as_written(self):
        with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as f:
            readme = f.read()
        commands = [ln[4:] for ln in readme.splitlines()
                    if re.match(r"    brakefitd? ", ln) and "/etc/" not in ln
                    and not re.match(r"    brakefit events list", ln)
                    # the central server's lines run against a server tests/fleet starts
                    and not re.match(r"    brakefit (fleet|sync) ", ln)]
        self.assertGreaterEqual(len(commands), 14, commands)
        self.assertTrue(any("config/examples/replay.toml" in c for c in commands))
        path_line = [ln[4:] for ln in readme.splitlines() if ln.startswith("    export PATH=")]
        self.assertEqual(len(path_line), 1)
        bindirs = [os.path.dirname(BIN), os.path.dirname(os.environ["BRAKEFITD_BIN"])]
        with tempfile.TemporaryDirectory() as d:
            # The clone's root as the README sees it: its data, scenarios and config; the outputs
            # land under out/ here, not in the source tree.
            for sub in ("data", "sim", "config"):
                os.symlink(os.path.join(ROOT, sub), os.path.join(d, sub))
            env = dict(os.environ, PATH=os.pathsep.join(bindirs + [os.environ["PATH"]]))
            for cmd in commands:
                r = subprocess.run(["bash", "-c", cmd], cwd=d, env=env, capture_output=True,
                                   text=True, timeout=600)
                self.assertEqual(r.returncode, 0, f"{cmd}\n{r.stderr[-2000:]}")
            # Nothing lands beside the data: every output is under out/.
            self.assertEqual(sorted(os.listdir(d)), ["config", "data", "out", "sim"])
        # The PATH line names the directories the build writes the binaries to.
        self.assertIn("build/release/cli", path_line[0])
        self.assertIn("build/release/daemon", path_line[0])


class FitsAtABound(unittest.TestCase):
    """A parameter the bound set, not the data, is named; "peak beyond the data" only when so."""

    def test_bounds_are_named_with_the_reason_for_a_null_standard_error(self):
        # The instrument's raw force on these runs is no tyre's curve: the fit ends on a bound
        # of C or E (which one depends on the start the hybrid keeps).
        for log in ("roller_1p0bar_medium", "ground_1p0bar_150barps"):
            r = run("replay", "--json", "--method", "hybrid", os.path.join(REC, log + ".log"))
            self.assertEqual(r.returncode, 0, r.stderr)
            res = json.loads(r.stdout.splitlines()[0])["results"][0]
            self.assertEqual(len(res["at_bound"]), 1, log)
            param = res["at_bound"][0]
            self.assertIn(param, ("C", "E"), log)
            self.assertIsNone(res["stderr"][param])
            self.assertIn("bound", res["stderr_null_reason"][param])
            for other in set("BCDE") - {param}:
                self.assertIsNotNone(res["stderr"][other], (log, other))
            self.assertFalse(res["peak_beyond_data"], log)
            table = run("replay", "--method", "hybrid", os.path.join(REC, log + ".log")).stdout
            self.assertIn(f"({param} at bound", table)
            self.assertNotIn("peak beyond the data", table)
        with tempfile.TemporaryDirectory() as d:
            # Data that stop at 4 % slip, before the peak (about 10 %): said, with no bound.
            csv = os.path.join(d, "early.csv")
            r = run("synth", "--B", "15", "--C", "1.6", "--D", "4000", "--E", "0.3",
                    "--slip-max", "0.04", "--out", csv)
            self.assertEqual(r.returncode, 0, r.stderr)
            svg = os.path.join(d, "p.svg")
            r = run("fit", "--json", "--method", "lm", "--plot", svg, csv)
            self.assertEqual(r.returncode, 0, r.stderr)
            res = json.loads(r.stdout)["results"][0]
            self.assertTrue(res["peak_beyond_data"])
            self.assertFalse(res["peak_reached"])
            _, series = svg_series(svg)
            self.assertTrue(any("peak beyond the data" in s for s in series), series)


if __name__ == "__main__":
    unittest.main()
