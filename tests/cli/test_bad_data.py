"""Bad data is never taken silently by `brakefit replay`: a text line inside a recorded log is an
error naming FILE:LINE (counted and warned under --lenient), and an event file whose speeds lie
outside physical ranges ends its event flagged implausible_data, left out with the reason, never
fitted."""
import json
import os
import subprocess
import tempfile
import unittest

BIN = os.environ["BRAKEFIT_BIN"]
ROOT = os.environ["BRAKEFIT_ROOT"]
REC = os.path.join(ROOT, "data", "recorded")
MODEL = os.path.join(ROOT, "data", "models", "default.json")


def run(*args):
    return subprocess.run([BIN, *args], capture_output=True, text=True, timeout=120)


class MalformedLogLines(unittest.TestCase):
    def test_text_inside_a_log_is_an_error_or_counted_when_lenient(self):
        log = os.path.join(REC, "roller_2p2bar_fast.log")
        bench = os.path.join(REC, "roller_2p2bar_fast.bench.toml")
        with open(log) as f:
            lines = f.readlines()
        with tempfile.TemporaryDirectory() as d:
            bad = os.path.join(d, "noted.log")
            # 118 lines of an operator's notes pasted into the middle of the recording.
            with open(bad, "w") as f:
                f.writelines(lines[:500] + [f"note {i}: checked the rollers\n" for i in range(118)]
                             + lines[500:])
            r = run("replay", "--json", "--model", MODEL, "--bench", bench, bad)
            self.assertEqual(r.returncode, 65, r.stderr)
            self.assertIn(f"{bad}:501: not a candump line", r.stderr)
            self.assertEqual(r.stdout, "")
            r = run("replay", "--json", "--lenient", "--model", MODEL, "--bench", bench, bad)
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertIn("118 malformed lines skipped (--lenient)", r.stderr)
            clean = run("replay", "--json", "--model", MODEL, "--bench", bench, log)
            self.assertEqual([json.loads(x)["results"] for x in r.stdout.splitlines()],
                             [json.loads(x)["results"] for x in clean.stdout.splitlines()])


class ImplausibleEventFiles(unittest.TestCase):
    def event_file(self, d, every, column, value):
        rows = []
        for i in range(600):
            t = i * 0.001
            v_ref = 1.389
            slip = 0.25 * i / 600
            row = {"t_s": f"{t:.3f}", "v_ref_mps": f"{v_ref:.4f}",
                   "v_wheel_mps": f"{v_ref * (1 - slip):.4f}", "pressure_bar": f"{3 + 0.1 * i:.3f}"}
            if i % every == every - 1:
                row[column] = value
            rows.append(",".join(row.values()))
        path = os.path.join(d, f"{column}.csv")
        with open(path, "w") as f:
            f.write("# bench=roller\n# wheel_radius_m=0.3\n# wheel_load_n=3800\n"
                    "# brake_gain_n_per_bar=66.7\n# tyre_pressure_bar=2.2\n# speed_kmh=5\n"
                    "t_s,v_ref_mps,v_wheel_mps,pressure_bar\n" + "\n".join(rows) + "\n")
        return path

    def test_speeds_outside_physical_ranges_are_flagged_not_fitted(self):
        with tempfile.TemporaryDirectory() as d:
            for every, column, value, why in ((4, "v_ref_mps", "1e308", "v_ref_mps 1e+308"),
                                              (3, "v_wheel_mps", "-5", "v_wheel_mps -5")):
                with self.subTest(column=column):
                    path = self.event_file(d, every, column, value)
                    r = run("replay", "--json", "--model", MODEL, path)
                    self.assertEqual(r.returncode, 0, r.stderr)
                    docs = [json.loads(x) for x in r.stdout.splitlines()]
                    self.assertEqual(len(docs), 1)
                    self.assertEqual(docs[0]["end_reason"], "implausible_data")
                    self.assertIn("implausible_data", docs[0]["flags"])
                    self.assertEqual(docs[0]["results"], [])
                    self.assertIn(why, docs[0]["end_note"])


if __name__ == "__main__":
    unittest.main()
