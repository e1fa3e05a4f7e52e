"""Recorded tests: simulate, replay, export, compare, and candump compatibility with can-utils."""
import glob
import json
import math
import os
import random
import shutil
import subprocess
import tempfile
import unittest
import xml.etree.ElementTree as ET

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


if __name__ == "__main__":
    unittest.main()


def others_roller_export(rate_bar_per_s, seed, step_mps=0.0005, last_slip=0.266, gain=66.7):
    """A roller stop as another tester exports it (written here, not by brakefit): 1 kHz, speeds
    quantised to 0.5 mm/s, pressure with 0.02 bar noise, no speed_timing key, and the last row
    just short of the 27 % switch-off (the tester switched off on its own filtered slip)."""
    B, C, D, E = 12.0, 1.6, 4000.0, 0.3

    def mf(s):
        x = B * s
        return D * math.sin(C * math.atan(x - E * (x - math.atan(x))))

    peak = max((i / 10000 for i in range(1, 5000)), key=mf)
    rng = random.Random(seed)
    q = lambda x: round(x / step_mps) * step_mps
    rows = ["# bench=roller", "# wheel_radius_m=0.3", f"# brake_gain_n_per_bar={gain}",
            "t_s,v_ref_mps,v_wheel_mps,pressure_bar"]
    v, t_past, i = 1.3889, None, 0
    while True:
        t = i * 1e-3
        p = max(0.0, rate_bar_per_s * (t - 0.2))
        lo, hi = 0.0, peak
        for _ in range(50):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if mf(mid) < gain * p else (lo, mid)
        if t_past is None and gain * p >= mf(peak):
            t_past = t
        if t_past is not None:  # a light wheel runs away; the brake holds the tyre's force
            lo = peak + 2.0 * (t - t_past)
        s = min(lo, last_slip)
        if t_past is not None:
            p = mf(s) / gain
        p = max(0.0, p + rng.gauss(0, 0.02))
        rows.append(f"{t:.6f},{q(v):.6f},{q(v * (1 - s)):.6f},{p:.3f}")
        if s >= last_slip:
            return "\n".join(rows) + "\n"
        i += 1


class OthersEventFiles(unittest.TestCase):
    """Event files brakefit did not write: each is one event, ended by its last row."""

    def test_replay_and_gap_read_them_as_finished_events(self):
        with tempfile.TemporaryDirectory() as d:
            runs = [write(d, f"run{k}.csv", others_roller_export(rate, 7 + k))
                    for k, rate in enumerate((10, 25, 60))]
            idle = write(d, "idle.csv", "# bench=roller\n# wheel_radius_m=0.3\n"
                         "t_s,v_ref_mps,v_wheel_mps,pressure_bar\n" +
                         "".join(f"{i * 1e-3:.3f},1.389,1.389,0.000\n" for i in range(2000)))
            r = run("replay", "--json", runs[0])
            self.assertEqual(r.returncode, 0, r.stderr)
            ev = json.loads(r.stdout.splitlines()[0])
            self.assertEqual(ev["end_reason"], "end_of_file")
            self.assertEqual(ev["flags"], [])
            self.assertAlmostEqual(ev["max_slip_ratio"], 0.266, delta=0.002)
            r = run("gap", "--json", *runs, idle)
            self.assertEqual(r.returncode, 0, r.stderr)
            doc = json.loads(r.stdout)
            self.assertEqual(len(doc["runs"]), 3)
            # Nothing dropped silently: the file without an event is named, on stderr and in JSON.
            self.assertEqual([(x["file"], x["event_id"]) for x in doc["left_out"]], [(idle, 0)])
            self.assertIn("idle.csv", r.stderr)
            # The floor's two parts: force noise (0.02 bar x 66.7 N/bar = 1.3 N) and the
            # quantised speeds' slip noise through the slope.
            self.assertAlmostEqual(doc["floor"]["force_n"], 1.33, delta=0.4)
            self.assertGreater(doc["floor"]["slip_n"], 0.0)
            self.assertAlmostEqual(doc["floor"]["v_wheel_step_mps"], 0.0005, delta=1e-6)
            self.assertAlmostEqual(doc["floor"]["total_n"],
                                   math.hypot(doc["floor"]["force_n"], doc["floor"]["slip_n"]), 6)
            # A Magic Formula tyre with nothing else: the verdict is none, the gap at the floor.
            self.assertEqual(doc["verdict"], ["none"])
            self.assertLess(doc["gap_before_rmse_n"], 1.3 * doc["floor"]["total_n"])


class Gap(unittest.TestCase):
    def test_json_and_report_on_the_shipped_roller_runs(self):
        with tempfile.TemporaryDirectory() as d:
            runs = recorded("roller_2p2bar_*.log")
            r = run("gap", "--json", "--report", d, *runs)
            self.assertEqual(r.returncode, 0, r.stderr)
            doc = json.loads(r.stdout)
            self.assertEqual(doc["schema"], "brakefit.gap/1")
            self.assertTrue(doc["model_hash"].startswith("sha256:"))
            self.assertIsInstance(doc["verdict"], list)
            self.assertEqual(len(doc["runs"]), 3)
            names = {e["name"] for e in doc["effects"]}
            for required in ("relaxation_length", "time_offset", "wheel_inertia", "brake_threshold",
                             "slip_offset", "load_transfer", "speed_friction"):
                self.assertIn(required, names)
            for e in doc["effects"]:
                self.assertAlmostEqual(e["gain"], 1 - e["heldout_rmse_after_n"] / e["heldout_rmse_before_n"], 9)
            # The recordings were simulated with a 0.2 m relaxation length: it is accepted first,
            # with the right magnitude, and the gap shrinks on withheld runs.
            self.assertEqual(doc["verdict"][0], "relaxation_length")
            relax = next(e for e in doc["effects"] if e["name"] == "relaxation_length")
            self.assertTrue(relax["accepted"])
            self.assertAlmostEqual(relax["params"]["sigma_m"], 0.2, delta=0.05)
            self.assertIn("sigma_m", doc["parameters_after"])
            self.assertLess(doc["gap_after_rmse_n"], 0.5 * doc["gap_before_rmse_n"])
            # Roller runs: the roller's null-calibrated gates; what is left after the accepted
            # effects is near the force noise (measured 3.9 N against 3.2 N).
            self.assertEqual(doc["condition"], "roller")
            self.assertGreaterEqual(doc["gates"]["gain"], 0.1)
            self.assertEqual(doc["gates"]["fit_quality_factor"], 1.5)  # the default
            self.assertLess(doc["gap_after_rmse_n"], 1.5 * doc["noise_n"])
            with open(os.path.join(d, "index.html")) as f:
                html = f.read()
            self.assertIn("Condition <b>roller</b>", html)
            # The residual is cut three ways; each cut is its own group summing to 100 %.
            for prefix, title in (("", "by slip region"), ("phase:", "by phase of the stop"),
                                  ("run:", "by run")):
                group = [w for w in doc["where"] if (w["region"].startswith(prefix) if prefix
                                                     else ":" not in w["region"])]
                self.assertAlmostEqual(sum(w["share"] for w in group), 1.0, 6, prefix)
                self.assertIn(f"<th colspan=\"3\">{title}</th>", html)
            for f in ("index.html", "residual.svg", "curves.svg", "gap.json"):
                self.assertTrue(os.path.exists(os.path.join(d, f)), f)
            self.assertEqual(len(svg_series(os.path.join(d, "residual.svg"))[1]), 3)

    def test_one_run_is_not_enough(self):
        r = run("gap", os.path.join(REC, "roller_2p2bar_fast.log"))
        self.assertEqual(r.returncode, 65)
        self.assertIn("at least two runs", r.stderr)

    def test_runs_of_two_benches_are_refused_in_mode_1(self):
        r = run("gap", os.path.join(REC, "roller_2p2bar_fast.log"),
                os.path.join(REC, "ground_2p2bar_150barps.log"))
        self.assertEqual(r.returncode, 65)
        self.assertIn("--roller and --road", r.stderr)
        self.assertIn("ground_2p2bar_150barps", r.stderr)

    def test_a_cradle_cap_on_simulated_roller_runs_is_named_with_its_force(self):
        # Roller runs simulated with the cradle capping the force at 3 000 N (wheel 1 kg m^2),
        # against the shipped road runs: the verdict starts with cradle_cap and says the cap.
        with tempfile.TemporaryDirectory() as d:
            scen = os.path.join(d, "capped.toml")
            with open(scen, "w") as f:
                f.write('[scenario]\nbench = "roller"\nseed = 5\n'
                        '[effects]\ncradle_cap_ratio = 0.789\npressure_noise_bar = 0.05\n')
            roller = []
            for ramp in ("slow", "medium", "fast"):
                out = os.path.join(d, f"capped_{ramp}.log")
                r = run("simulate", scen, "--ramp", ramp, "--out", out)
                self.assertEqual(r.returncode, 0, r.stderr)
                roller.append(out)
            r = run("gap", "--json", "--report", os.path.join(d, "rep"), *roller)
            self.assertEqual(r.returncode, 0, r.stderr)
            doc = json.loads(r.stdout)
            self.assertEqual(doc["verdict"][0], "cradle_cap", doc["notes"])
            cap = next(e for e in doc["effects"] if e["name"] == "cradle_cap")
            self.assertAlmostEqual(cap["params"]["cap_n"], 0.789 * 3800, delta=0.05 * 3000)
            with open(os.path.join(d, "rep", "index.html")) as f:
                self.assertIn("cradle_cap", f.read())

    def test_roller_vs_road_ranks_the_transfer_effects(self):
        roller, road = recorded("roller_2p2bar_*.log"), recorded("ground_2p2bar_*.log")
        r = run("gap", "--json", "--roller", *roller, "--road", *road)
        self.assertEqual(r.returncode, 0, r.stderr)
        doc = json.loads(r.stdout)
        self.assertEqual(doc["schema"], "brakefit.gap/1")
        self.assertEqual(doc["mode"], "roller_vs_road")
        self.assertEqual(doc["condition"], "roller_vs_road")
        # The roller runs are corrected for their own effects before their B, C, D, E travel.
        self.assertTrue(any("corrected for their own" in n for n in doc["notes"]), doc["notes"])
        names = {e["name"] for e in doc["effects"]}
        for required in ("load_transfer", "speed_friction", "roller_friction"):
            self.assertIn(required, names)
        # Every effect says at which stage it was scored and why it was or was not accepted.
        for e in doc["effects"]:
            self.assertTrue(e["stage"] == "alone" or e["stage"].startswith("forward selection"))
            self.assertTrue(e["decision"], e)
            self.assertEqual(e["accepted"], e["decision"].startswith(("accepted", "found")), e)
        table = run("gap", "--roller", *roller, "--road", *road).stdout
        self.assertIn("each effect alone against the baseline:", table)
        self.assertRegex(table, r"effect\s+parameters\s+gain\s+dBIC\s+decision")
        # The ground runs were simulated with load transfer and a road 1/0.85 grippier than the
        # rollers: one of those closes most of the gap on withheld road runs.
        self.assertIn(doc["verdict"][0], ("load_transfer", "roller_friction"))
        self.assertLess(doc["gap_after_rmse_n"], 0.3 * doc["gap_before_rmse_n"])
        # The roller's B, C, D, E are held: parameters_before equals parameters_after's first four.
        for k in "BCDE":
            self.assertAlmostEqual(doc["parameters_before"][k], doc["parameters_after"][k], 9)
        r = run("gap", "--roller", *roller)
        self.assertEqual(r.returncode, 78)


class ReadmeTour(unittest.TestCase):
    """Every command of the README's tour, as written, with the binaries on PATH as it says."""

    def test_every_tour_command_runs_as_written(self):
        with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as f:
            readme = f.read()
        tour = readme[readme.index("## A short tour"):]
        tour = tour[:tour.index("\n- ")]
        commands = [ln[4:] for ln in tour.splitlines() if ln.startswith("    brakefit")]
        self.assertGreaterEqual(len(commands), 5, tour)
        path_line = [ln[4:] for ln in tour.splitlines() if ln.startswith("    export PATH=")]
        self.assertEqual(len(path_line), 1)
        bindir = os.path.dirname(BIN)
        with tempfile.TemporaryDirectory() as d:
            # The clone's root as the tour sees it: its data, scenarios and config; the outputs
            # land here, not in the source tree.
            for sub in ("data", "sim", "config"):
                os.symlink(os.path.join(ROOT, sub), os.path.join(d, sub))
            env = dict(os.environ, PATH=bindir + os.pathsep + os.environ["PATH"])
            for cmd in commands:
                r = subprocess.run(["bash", "-c", cmd], cwd=d, env=env, capture_output=True,
                                   text=True, timeout=600)
                self.assertEqual(r.returncode, 0, f"{cmd}\n{r.stderr[-2000:]}")
        # The PATH line names the directories the build writes the binaries to.
        self.assertIn("build/release/cli", path_line[0])


class FitsAtABound(unittest.TestCase):
    """A parameter the bound set, not the data, is named; "peak beyond the data" only when so."""

    def test_bounds_are_named_with_the_reason_for_a_null_standard_error(self):
        for log, param in (("roller_1p0bar_medium", "E"), ("ground_1p0bar_150barps", "C")):
            r = run("replay", "--json", "--method", "hybrid", os.path.join(REC, log + ".log"))
            self.assertEqual(r.returncode, 0, r.stderr)
            res = json.loads(r.stdout.splitlines()[0])["results"][0]
            self.assertEqual(res["at_bound"], [param], log)
            self.assertIsNone(res["stderr"][param])
            self.assertIn("bound", res["stderr_null_reason"][param])
            self.assertFalse(res["peak_beyond_data"], log)
            table = run("replay", "--method", "hybrid", os.path.join(REC, log + ".log")).stdout
            self.assertIn(f"({param} at bound)", table)
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

