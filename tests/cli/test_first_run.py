"""What a new user meets first, each as it should be: a misspelled subcommand named with the
nearest one, exit codes as the README's table says (a missing scenario 66, one run for `gap` 64),
a curve CSV given to `replay` and a directory given to `fit` told what they are, --log-level
anywhere on the line, a least-squares curve hidden under an
identical hybrid one said so, and the roller-vs-road report naming the runs of both sides."""
import glob
import json
import os
import tempfile
import unittest

from test_cli import CURVES, ROOT, run, svg_series

REC = os.path.join(ROOT, "data", "recorded")


class FirstRun(unittest.TestCase):
    def test_a_misspelled_subcommand_is_named_with_the_nearest(self):
        r = run("relpay", os.path.join(REC, "roller_2p2bar_fast.log"))
        self.assertEqual(r.returncode, 64)
        self.assertIn("'relpay' is not a brakefit subcommand (did you mean 'replay'?)", r.stderr)
        r = run("--log-level", "warn", "zzzzzzzz")
        self.assertEqual(r.returncode, 64)
        self.assertIn("'zzzzzzzz' is not a brakefit subcommand;", r.stderr)

    def test_exit_codes_of_a_missing_scenario_and_a_single_run(self):
        with tempfile.TemporaryDirectory() as d:
            r = run("simulate", os.path.join(d, "nosuch.toml"), "--out", os.path.join(d, "x.log"))
            self.assertEqual(r.returncode, 66, r.stderr)
            self.assertIn("nosuch.toml: cannot open", r.stderr)
        r = run("gap", os.path.join(REC, "roller_2p2bar_fast.log"))
        self.assertEqual(r.returncode, 64, r.stderr)
        self.assertIn("1 run usable in 1 file", r.stderr)  # a count agrees with its noun

    def test_a_curve_csv_to_replay_and_a_directory_to_fit_are_told_what_they_are(self):
        curve = os.path.join(CURVES, "roller_car_1bar.csv")
        r = run("replay", curve)
        self.assertEqual(r.returncode, 65, r.stderr)
        self.assertIn("a curve CSV (slip, force_n), not a recording or an event file", r.stderr)
        self.assertNotIn("bench calibration", r.stderr)
        r = run("fit", CURVES)
        self.assertEqual(r.returncode, 66, r.stderr)
        self.assertIn(f"{CURVES}: is a directory", r.stderr)

    def test_log_level_anywhere_on_the_line(self):
        log = os.path.join(REC, "roller_2p2bar_fast.log")
        for args in (("--log-level", "warn", "replay", log), ("replay", log, "--log-level", "warn")):
            r = run(*args)
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertNotIn("[info]", r.stderr, args)

    def test_identical_lm_and_hybrid_curves_are_said_to_coincide(self):
        log = os.path.join(REC, "ground_2p2bar_150barps.log")
        r = run("replay", log)
        self.assertEqual(r.returncode, 0, r.stderr)
        lines = {ln.split()[0]: ln for ln in r.stdout.splitlines() if ln.startswith("  ")}
        self.assertIn("the same curve as hybrid", lines["lm"])
        self.assertIn("the same curve as lm", lines["hybrid"])
        self.assertNotIn("the same curve", lines["som"])
        with tempfile.TemporaryDirectory() as d:
            r = run("replay", "--report", d, log)
            self.assertEqual(r.returncode, 0, r.stderr)
            svg = sorted(glob.glob(os.path.join(d, "*.svg")))[0]
            _, series = svg_series(svg)
            self.assertTrue(any(s.startswith("lm ") and "the same curve as hybrid" in s
                                for s in series), series)

    def test_a_curve_no_tyre_gives_is_flagged_in_the_json_the_table_and_the_plot(self):
        # The ground recording at 150 bar/s: its least-squares fit ends with C at its bound and a
        # peak of 6.1 kN on a wheel loaded with 3.8 kN (the truth: 1.05).
        log = os.path.join(REC, "ground_2p2bar_150barps.log")
        r = run("replay", "--json", log)
        self.assertEqual(r.returncode, 0, r.stderr)
        by = {x["method"]: x for x in json.loads(r.stdout.splitlines()[0])["results"]}
        for m in ("lm", "hybrid"):
            self.assertTrue(any("peak friction" in w for w in by[m]["implausible"]), by[m])
            self.assertTrue(any("shape factor C" in w for w in by[m]["implausible"]), by[m])
        table = run("replay", log).stdout
        self.assertIn("NOT A TYRE'S CURVE: shape factor C 0.3", table)
        with tempfile.TemporaryDirectory() as d:
            self.assertEqual(run("replay", "--report", d, log).returncode, 0)
            _, series = svg_series(sorted(glob.glob(os.path.join(d, "*.svg")))[0])
            self.assertTrue(any(s.startswith("hybrid ") and "NOT A TYRE'S CURVE" in s
                                for s in series), series)
        # compare's table says which parameters the bound set and which side is no tyre's curve.
        roller = sorted(glob.glob(os.path.join(REC, "roller_2p2bar_*.log")))
        road = sorted(glob.glob(os.path.join(REC, "ground_2p2bar_*.log")))
        r = run("compare", "--roller", *roller, "--road", *road)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("0.3000 (at bound)", r.stdout)
        self.assertIn("road (3 runs): NOT A TYRE'S CURVE: shape factor C 0.3", r.stdout)
        self.assertIn("roller (3 runs): 3 events", r.stdout)
        # A roller recording fitted on the tyre's basis (its bench's model undone) is a tyre's
        # curve for every method: no such flag.
        r = run("replay", "--json", "--bench-model",
                os.path.join(ROOT, "data", "bench_models", "roller.bench.toml"),
                os.path.join(REC, "roller_2p2bar_medium.log"))
        self.assertEqual(r.returncode, 0, r.stderr)
        res = json.loads(r.stdout.splitlines()[0])["tyre_results"]
        self.assertEqual([x["method"] for x in res], ["som", "mlp", "lm", "hybrid"])
        self.assertEqual([x["implausible"] for x in res], [[], [], [], []])

    def test_the_roller_vs_road_report_names_both_sides_runs(self):
        roller = sorted(glob.glob(os.path.join(REC, "roller_2p2bar_*.log")))
        road = sorted(glob.glob(os.path.join(REC, "ground_2p2bar_*.log")))
        with tempfile.TemporaryDirectory() as d:
            r = run("gap", "--json", "--report", d, "--roller", *roller, "--road", *road)
            self.assertEqual(r.returncode, 0, r.stderr)
            doc = json.loads(r.stdout)
            self.assertEqual(len(doc["roller_runs"]), 3)
            self.assertEqual(len(doc["runs"]), 3)
            with open(os.path.join(d, "index.html")) as f:
                html = f.read()
            self.assertIn("Roller runs (fitted): roller_2p2bar_fast#1", html)
            self.assertIn("Road runs (predicted): ground_2p2bar_100barps#1", html)


if __name__ == "__main__":
    unittest.main()
