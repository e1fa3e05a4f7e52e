"""Generator C's suite bench (issue 34): bench/gap_c_suite.py scores each set's `brakefit gap`
verdict against the suite's truth and writes its table into a results file's own section. Run
here on a suite written in the test and a stand-in brakefit that answers each set as told (no
test depends on ../shared)."""
import json
import os
import stat
import subprocess
import sys
import tempfile
import unittest

from test_cli import ROOT

SCRIPT = os.path.join(ROOT, "bench", "gap_c_suite.py")

# Each case: its truth, and the stand-in's answer (verdict, parameters_after[, effects]).
CASES = [
    ({"bench": "roller", "effect": "time_offset", "magnitude": 0.05},
     (["relaxation_length", "time_offset"], {"sigma_m": 0.07})),  # a lag for a delay at one
    # roller speed: named, the delay beside it no extra name
    ({"bench": "roller", "effect": "slip_offset", "magnitude": 0.01},
     (["slip_offset"], {"slip_offset_ratio": -0.0102})),  # C's offset reads as the negative
    ({"bench": "ground", "effect": "load_transfer", "magnitude": 0.25, "tyre": "sedan_pac02"},
     (["load_transfer", "unexplained"], {"dfz_per_decel_s2_per_m": 0.5},  # the model's own q
      [{"name": "load_transfer", "accepted": True,  # the load's change the report gives
        "params": {"load_ratio_per_decel_s2_per_m": 0.25 * 3.4 / (2 * 9.81) * 1.1,
                   # the band at published tyres' laws: the truth (0.25) lies inside it
                   "load_ratio_per_decel_low_s2_per_m": 0.24 * 3.4 / (2 * 9.81),
                   "load_ratio_per_decel_high_s2_per_m": 0.3 * 3.4 / (2 * 9.81)}}])),
    ({"bench": "ground", "effect": "speed_friction", "magnitude": 1.0},
     (["unexplained"], {})),  # a miss
    ({"bench": "ground", "effect": "none", "magnitude": 0.0}, (["none"], {})),
    ({"bench": "ground", "effect": "none", "magnitude": 0.0}, (["relaxation_length"], {})),
    ({"bench": "roller", "effect": "misspec", "magnitude": 0.0}, (["unexplained"], {})),
    ({"bench": "ground", "effect": "slip_offset", "magnitude": 0.01},  # named, with an extra name
     (["slip_offset", "brake_threshold", "unexplained"], {"slip_offset_ratio": -0.0098})),
]

STAND_IN = """#!{python}
import json, os, sys
case = os.path.basename(os.path.dirname(sys.argv[-1]))
here = os.path.dirname(os.path.abspath(__file__))
answers = json.load(open(os.path.join(here, "answers.json")))
tir = open(sys.argv[sys.argv.index("--tir") + 1]).read() if "--tir" in sys.argv else None
with open(os.path.join(here, "calls.jsonl"), "a") as f:
    f.write(json.dumps({{"case": case, "tir": tir}}) + "\\n")
verdict, after, *effects = answers[case]
print(json.dumps({{"schema": "brakefit.gap/1", "verdict": verdict, "parameters_after": after,
                  "effects": effects[0] if effects else []}}))
"""


# A stand-in for gen_c.py: writes CASES as its suite, whatever the seed, and records the seed.
GEN_C = """
import json, os, sys
TYRES = {{  # C's table: a tyre's reference load and longitudinal coefficients
 "sedan_pac02": dict(FZ0=3928.5, PCX1=1.6411, PDX1=1.1739, PKX1=22.303, PKX2=0.48896),
}}
sys.path.insert(0, {here!r})
from test_gap_c_suite import write_suite
out, seed = sys.argv[1], int(sys.argv[sys.argv.index("--seed") + 1])
write_suite(out)
with open(os.path.join(out, "seed"), "w") as f:
    f.write(str(seed))
"""


def write_suite(suite):
    truth = []
    for i, (t, _) in enumerate(CASES):
        case = f"case{i:03d}"
        os.makedirs(os.path.join(suite, case))
        for r in range(3):
            with open(os.path.join(suite, case, f"run{r}.csv"), "w") as f:
                f.write("# bench=" + t["bench"] + "\n")
        truth.append(dict(t, case=case))
    with open(os.path.join(suite, "truth.json"), "w") as f:
        json.dump(truth, f)


def write_stand_in(build):
    os.makedirs(os.path.join(build, "cli"))
    with open(os.path.join(build, "cli", "answers.json"), "w") as f:
        json.dump({f"case{i:03d}": answer for i, (_, answer) in enumerate(CASES)}, f)
    stand_in = os.path.join(build, "cli", "brakefit")
    with open(stand_in, "w") as f:
        f.write(STAND_IN.format(python=sys.executable))
    os.chmod(stand_in, os.stat(stand_in).st_mode | stat.S_IEXEC)


def stand_ins(tmp):
    """A stand-in brakefit under tmp/build and a stand-in gen_c.py: (build, gen_c)."""
    build = os.path.join(tmp, "build")
    write_stand_in(build)
    gen_c = os.path.join(tmp, "gen_c.py")
    with open(gen_c, "w") as f:
        f.write(GEN_C.format(here=os.path.dirname(os.path.abspath(__file__))))
    return build, gen_c


class CSuite(unittest.TestCase):
    def test_scores_each_set_and_writes_its_section(self):
        with tempfile.TemporaryDirectory() as tmp:
            suite, build = os.path.join(tmp, "suite"), os.path.join(tmp, "build")
            write_suite(suite)
            write_stand_in(build)
            results = os.path.join(tmp, "results.md")
            with open(results, "w") as f:
                f.write("# R\n\n<!-- gap_c_suite begin -->\nold\n<!-- gap_c_suite end -->\n\nafter\n")
            p = subprocess.run([sys.executable, SCRIPT, "--set", suite, "--build", build,
                                "--results", results], capture_output=True, text=True, timeout=120)
            self.assertEqual(p.returncode, 0, p.stderr)
            doc = json.loads(p.stdout.strip().splitlines()[-1])
            self.assertEqual(doc["schema"], "brakefit.gap_c_suite/1")
            counts = doc["counts"]
            self.assertEqual((counts["single"]["ok"], counts["single"]["of"]), (4, 5))
            self.assertEqual((counts["alone"]["ok"], counts["alone"]["of"]), (3, 4))
            self.assertEqual(doc["extra_names"], [
                "case007 ground slip_offset 0.01 said ['slip_offset', 'brake_threshold', "
                "'unexplained']"])
            self.assertEqual((counts["null"]["ok"], counts["null"]["of"]), (1, 2))
            self.assertEqual((counts["misspec"]["ok"], counts["misspec"]["of"]), (1, 1))
            self.assertEqual((counts["false_claims"]["ok"], counts["false_claims"]["of"]), (1, 3))
            err = doc["magnitude_error_median"]
            self.assertAlmostEqual(err["slip_offset"], 0.02, places=6)
            self.assertAlmostEqual(err["load_transfer"], 0.10, places=6)
            self.assertNotIn("time_offset", err)  # the lag named has no delay to measure
            self.assertEqual(list(doc["load_transfer_error_median_by_tyre"]), ["sedan_pac02"])
            self.assertAlmostEqual(doc["load_transfer_error_median_by_tyre"]["sedan_pac02"], 0.10)
            self.assertEqual(len(doc["misses"]), 2)
            with open(results) as f:
                text = f.read()
            self.assertNotIn("\nold\n", text)
            self.assertIn("4 of 5 (80 %)", text)
            self.assertIn("roller the lag's twin aside) | 3 of 4 (75 %) |", text)
            self.assertIn("bench/gap_c_suite.py", text)
            self.assertTrue(text.rstrip().endswith("after"))
            self.assertIn("| load transfer's error by tyre, median (sets) | sedan_pac02 10.0 % (1) |",
                          text)
            self.assertEqual(doc["load_transfer_inside_published_band_by_tyre"],
                             {"sedan_pac02": {"inside": 1, "of": 1}})
            self.assertIn("published tyres' load laws (by tyre) | 1 of 1 (100 %); sedan_pac02 1 of 1 |",
                          text)

    def test_several_seeds_pool_their_suites_into_a_block_of_its_own(self):
        with tempfile.TemporaryDirectory() as tmp:
            build, gen_c = stand_ins(tmp)
            results = os.path.join(tmp, "results.md")
            with open(results, "w") as f:
                f.write("# R\n\n<!-- gap_c_suite begin -->\nseed 77\n<!-- gap_c_suite end -->\n")
            p = subprocess.run([sys.executable, SCRIPT, "--gen-c", gen_c, "--seed", "5,11",
                                "--build", build, "--results", results, "--results-key",
                                "more seeds"], capture_output=True, text=True, timeout=120)
            self.assertEqual(p.returncode, 0, p.stderr)
            doc = json.loads(p.stdout.strip().splitlines()[-1])
            self.assertEqual(doc["seeds"], [5, 11])
            self.assertEqual(doc["sets"], 2 * len(CASES))
            self.assertEqual((doc["counts"]["single"]["ok"], doc["counts"]["single"]["of"]), (8, 10))
            self.assertEqual(sorted(m.split()[0] for m in doc["misses"]),
                             ["seed11/case003", "seed11/case005", "seed5/case003", "seed5/case005"])
            with open(results) as f:
                text = f.read()
            self.assertIn("<!-- gap_c_suite begin -->\nseed 77\n<!-- gap_c_suite end -->", text)
            self.assertIn("<!-- gap_c_suite more seeds begin -->", text)
            self.assertIn("sets of generator C, seeds 5, 11", text)
            self.assertIn("8 of 10 (80 %)", text)

    def test_with_tir_each_set_gets_its_tyres_file_from_generator_cs_table(self):
        with tempfile.TemporaryDirectory() as tmp:
            build, gen_c = stand_ins(tmp)
            p = subprocess.run([sys.executable, SCRIPT, "--gen-c", gen_c, "--seed", "3", "--tir",
                                "--build", build], capture_output=True, text=True, timeout=120)
            self.assertEqual(p.returncode, 0, p.stderr)
            with open(os.path.join(build, "cli", "calls.jsonl")) as f:
                calls = {c["case"]: c["tir"] for c in map(json.loads, f)}
            self.assertEqual(len(calls), len(CASES))
            tyred = [f"case{i:03d}" for i, (t, _) in enumerate(CASES) if "tyre" in t]
            self.assertEqual(sorted(c for c, tir in calls.items() if tir), tyred)
            tir = calls[tyred[0]]
            self.assertIn("[VERTICAL]\nFNOMIN = 3928.5\n", tir)
            self.assertIn("[LONGITUDINAL_COEFFICIENTS]\n", tir)
            for line in ("PCX1 = 1.6411", "PDX1 = 1.1739", "PKX1 = 22.303", "PKX2 = 0.48896"):
                self.assertIn(line + "\n", tir)
            self.assertNotIn("FZ0", tir)
            # A script without the table is refused, naming it.
            with open(gen_c, "w") as f:
                f.write("print('no tyres here')\n")
            p = subprocess.run([sys.executable, SCRIPT, "--gen-c", gen_c, "--tir", "--build",
                                build], capture_output=True, text=True, timeout=120)
            self.assertNotEqual(p.returncode, 0)
            self.assertIn(f"{gen_c} has no TYRES table", p.stderr)

    def test_a_seed_that_is_not_a_number_is_an_error_naming_the_option(self):
        p = subprocess.run([sys.executable, SCRIPT, "--seed", "5,x"], capture_output=True,
                           text=True, timeout=60)
        self.assertEqual(p.returncode, 2)
        self.assertIn("--seed", p.stderr)
        self.assertIn("5,x", p.stderr)


if __name__ == "__main__":
    unittest.main()
