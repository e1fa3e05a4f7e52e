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

# Each case: its truth, and the stand-in's answer (verdict, parameters_after).
CASES = [
    ({"bench": "roller", "effect": "time_offset", "magnitude": 0.05},
     (["relaxation_length"], {"sigma_m": 0.07})),  # a lag for a delay at one roller speed: named
    ({"bench": "roller", "effect": "slip_offset", "magnitude": 0.01},
     (["slip_offset"], {"slip_offset_ratio": -0.0102})),  # C's offset reads as the negative
    ({"bench": "ground", "effect": "load_transfer", "magnitude": 0.25},
     (["load_transfer", "unexplained"], {"dfz_per_decel_s2_per_m": 0.25 * 3.4 / (2 * 9.81) * 1.1})),
    ({"bench": "ground", "effect": "speed_friction", "magnitude": 1.0},
     (["unexplained"], {})),  # a miss
    ({"bench": "ground", "effect": "none", "magnitude": 0.0}, (["none"], {})),
    ({"bench": "ground", "effect": "none", "magnitude": 0.0}, (["relaxation_length"], {})),
    ({"bench": "roller", "effect": "misspec", "magnitude": 0.0}, (["unexplained"], {})),
]

STAND_IN = """#!{python}
import json, os, sys
case = os.path.basename(os.path.dirname(sys.argv[-1]))
answers = json.load(open(os.path.join(os.path.dirname(os.path.abspath(__file__)), "answers.json")))
verdict, after = answers[case]
print(json.dumps({{"schema": "brakefit.gap/1", "verdict": verdict, "parameters_after": after}}))
"""


class CSuite(unittest.TestCase):
    def test_scores_each_set_and_writes_its_section(self):
        with tempfile.TemporaryDirectory() as tmp:
            suite, build = os.path.join(tmp, "suite"), os.path.join(tmp, "build")
            os.makedirs(os.path.join(build, "cli"))
            truth, answers = [], {}
            for i, (t, answer) in enumerate(CASES):
                case = f"case{i:03d}"
                os.makedirs(os.path.join(suite, case))
                for r in range(3):
                    with open(os.path.join(suite, case, f"run{r}.csv"), "w") as f:
                        f.write("# bench=" + t["bench"] + "\n")
                truth.append(dict(t, case=case))
                answers[case] = answer
            with open(os.path.join(suite, "truth.json"), "w") as f:
                json.dump(truth, f)
            with open(os.path.join(build, "cli", "answers.json"), "w") as f:
                json.dump(answers, f)
            stand_in = os.path.join(build, "cli", "brakefit")
            with open(stand_in, "w") as f:
                f.write(STAND_IN.format(python=sys.executable))
            os.chmod(stand_in, os.stat(stand_in).st_mode | stat.S_IEXEC)
            results = os.path.join(tmp, "results.md")
            with open(results, "w") as f:
                f.write("# R\n\n<!-- gap_c_suite begin -->\nold\n<!-- gap_c_suite end -->\n\nafter\n")
            p = subprocess.run([sys.executable, SCRIPT, "--set", suite, "--build", build,
                                "--results", results], capture_output=True, text=True, timeout=120)
            self.assertEqual(p.returncode, 0, p.stderr)
            doc = json.loads(p.stdout.strip().splitlines()[-1])
            self.assertEqual(doc["schema"], "brakefit.gap_c_suite/1")
            counts = doc["counts"]
            self.assertEqual((counts["single"]["ok"], counts["single"]["of"]), (3, 4))
            self.assertEqual((counts["null"]["ok"], counts["null"]["of"]), (1, 2))
            self.assertEqual((counts["misspec"]["ok"], counts["misspec"]["of"]), (1, 1))
            self.assertEqual((counts["false_claims"]["ok"], counts["false_claims"]["of"]), (1, 3))
            err = doc["magnitude_error_median"]
            self.assertAlmostEqual(err["slip_offset"], 0.02, places=6)
            self.assertAlmostEqual(err["load_transfer"], 0.10, places=6)
            self.assertNotIn("time_offset", err)  # the lag named has no delay to measure
            self.assertEqual(len(doc["misses"]), 2)
            with open(results) as f:
                text = f.read()
            self.assertNotIn("\nold\n", text)
            self.assertIn("3 of 4 (75 %)", text)
            self.assertIn("bench/gap_c_suite.py", text)
            self.assertTrue(text.rstrip().endswith("after"))


if __name__ == "__main__":
    unittest.main()
