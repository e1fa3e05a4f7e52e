"""brakefit CLI: exit codes, JSON shape, error messages, SVG plots (run by ctest)."""
import json
import math
import os
import re
import subprocess
import tempfile
import unittest
import xml.etree.ElementTree as ET

BIN = os.environ["BRAKEFIT_BIN"]
ROOT = os.environ["BRAKEFIT_ROOT"]
CURVES = os.path.join(ROOT, "data", "curves")
SVG = "{http://www.w3.org/2000/svg}"


def run(*args, env=None):
    e = dict(os.environ)
    e.pop("BRAKEFIT_MODEL", None)
    if env:
        e.update(env)
    return subprocess.run([BIN, *args], capture_output=True, text=True, env=e, timeout=120)


def write(dirname, name, text):
    path = os.path.join(dirname, name)
    with open(path, "w") as f:
        f.write(text)
    return path


def pac96(s, b, c, d, e):
    """The Magic Formula (Pac96's longitudinal force), for exports the tests write themselves."""
    x = b * s
    return d * math.sin(c * math.atan(x - e * (x - math.atan(x))))


def slip_on_rise(force_of, force_n, peak_s):
    """The slip in [0, peak_s] at which force_of(slip) reaches force_n (bisection)."""
    lo, hi = 0.0, peak_s
    for _ in range(50):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if force_of(mid) < force_n else (lo, mid)
    return lo


def good_rows(n=10):
    return "".join(f"{0.02 * i:.3f},{300.0 * i:.1f}\n" for i in range(1, n + 1))


class Version(unittest.TestCase):
    def test_version(self):
        r = run("--version")
        self.assertEqual(r.returncode, 0)
        self.assertRegex(r.stdout.strip(), r"^brakefit \d+\.\d+\.\d+$")


class FitJson(unittest.TestCase):
    def test_batch_json_documents(self):
        files = [os.path.join(CURVES, f) for f in ("roller_car_1bar.csv", "ground_car_1bar.csv", "truck_nominal.csv")]
        r = run("fit", "--method", "all", "--json", *files)
        self.assertEqual(r.returncode, 0, r.stderr)
        docs = [json.loads(line) for line in r.stdout.splitlines()]
        self.assertEqual(len(docs), 3)
        for doc, f in zip(docs, files):
            self.assertEqual(doc["schema"], "brakefit.fit/1")
            self.assertRegex(doc["version"], r"^\d+\.\d+\.\d+$")
            self.assertRegex(doc["model_hash"], r"^sha256:[0-9a-f]{64}$")
            self.assertEqual(doc["file"], f)
            self.assertEqual([x["method"] for x in doc["results"]], ["som", "mlp", "lm", "hybrid"])
            for res in doc["results"]:
                for k in ("B", "C", "D", "E", "mape_pct", "mape_points_excluded", "rmse_n", "peak_reached", "stderr"):
                    self.assertIn(k, res)
                if res["method"] in ("som", "mlp"):
                    self.assertIsNone(res["stderr"])
                else:
                    self.assertEqual(set(res["stderr"]), {"B", "C", "D", "E"})
        # The ground curve is given in percent but B is always per unit slip ratio (true B = 13).
        self.assertEqual(docs[1]["slip_unit"], "percent")
        self.assertEqual(docs[0]["slip_unit"], "ratio")
        hybrid = docs[1]["results"][3]
        self.assertAlmostEqual(hybrid["B"], 13.0, delta=0.5)
        self.assertLess(hybrid["mape_pct"], 2.0)
        self.assertTrue(hybrid["peak_reached"])

    def test_lm_without_model_has_null_hash(self):
        r = run("fit", "--method", "lm", "--json", os.path.join(CURVES, "roller_car_1bar.csv"),
                env={"BRAKEFIT_MODEL": "/nonexistent"})
        self.assertEqual(r.returncode, 0, r.stderr)
        doc = json.loads(r.stdout)
        self.assertIsNone(doc["model_hash"])
        self.assertEqual(len(doc["results"]), 1)

    def test_table_in_percent(self):
        r = run("fit", "--slip-unit", "percent", os.path.join(CURVES, "ground_car_1bar.csv"))
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("B [1/%]", r.stdout)
        row = [line for line in r.stdout.splitlines() if line.strip().startswith("hybrid")][0]
        self.assertAlmostEqual(float(row.split()[1]), 0.13, delta=0.005)  # the paper's unit

    def test_the_shipped_mlp_reads_a_curve_measured_to_any_slip(self):
        # A car's tyre measured to 20, 45, 70 and 87 % slip (a ground run whose wheel does not run
        # away): every end lies among the ends the shipped network was trained on, so its estimate
        # is a plain result within 2 % of the peak. (Trained on cuts up to 60 % only, it returned
        # E 2 and 73 % off for the 87 % curve.)
        true = (12.7, 1.63, 4685.0, 0.61)
        with tempfile.TemporaryDirectory() as d:
            for end in (0.20, 0.45, 0.70, 0.87):
                rows = "".join(f"{end * i / 200:.5f},{pac96(end * i / 200, *true):.2f}\n"
                               for i in range(201))
                path = write(d, f"to{end}.csv", "slip,force_n\n" + rows)
                r = run("fit", "--method", "mlp", "--json", path)
                self.assertEqual(r.returncode, 0, r.stderr)
                mlp = json.loads(r.stdout)["results"][0]
                self.assertEqual(mlp["implausible"], [], (end, mlp))
                self.assertLess(mlp["rmse_pct_peak"], 2.0, (end, mlp))


class BadInput(unittest.TestCase):
    CASES = {
        "missing_column.csv": ("slip,load\n" + good_rows(), r":1: header must name"),
        "non_numeric.csv": ("slip,force_n\n0.01,1\n0.02,x\n" + good_rows(), r":3: column 'force_n': 'x' is not a number"),
        "nan.csv": ("slip,force_n\n0.01,nan\n" + good_rows(), r":2: column 'force_n': value 'nan' is not finite"),
        "few.csv": ("slip,force_n\n" + good_rows(7), r":\d+: only 7 data points"),
        "outside.csv": ("slip_pct,force_n\n10,1\n120,2\n" + good_rows(), r":3: column 'slip_pct': slip 120 is outside"),
    }

    def test_each_bad_file_names_file_and_line_and_prints_nothing(self):
        with tempfile.TemporaryDirectory() as d:
            good = os.path.join(CURVES, "roller_car_1bar.csv")
            for name, (text, pattern) in self.CASES.items():
                bad = write(d, name, text)
                plot = os.path.join(d, "p.svg")
                r = run("fit", "--json", "--plot", plot, good, bad)  # the good file comes first
                self.assertEqual(r.returncode, 65, name)
                self.assertEqual(r.stdout, "", f"{name}: partial output")
                self.assertFalse(os.path.exists(plot), f"{name}: partial plot")
                self.assertRegex(r.stderr, re.escape(bad) + pattern, name)

    def test_missing_file(self):
        r = run("fit", "/nonexistent/curve.csv")
        self.assertEqual(r.returncode, 66)
        self.assertIn("/nonexistent/curve.csv", r.stderr)

    def test_corrupt_model(self):
        with tempfile.TemporaryDirectory() as d:
            with open(os.path.join(ROOT, "data", "models", "default.json")) as f:
                text = f.read()
            i = text.index('"codebook"') + 30
            j = next(k for k in range(i, len(text)) if text[k] in "1234567")
            bad = write(d, "m.json", text[:j] + str(int(text[j]) + 1) + text[j + 1:])
            r = run("fit", "--model", bad, os.path.join(CURVES, "roller_car_1bar.csv"))
            self.assertEqual(r.returncode, 65)
            self.assertIn(bad + ": model is corrupt: checksum mismatch", r.stderr)
            trunc = write(d, "t.json", text[: len(text) // 3])
            r = run("fit", "--model", trunc, os.path.join(CURVES, "roller_car_1bar.csv"))
            self.assertEqual(r.returncode, 65)
            self.assertIn("corrupt or truncated", r.stderr)

    def test_bad_train_config_exits_78_naming_the_key(self):
        with tempfile.TemporaryDirectory() as d:
            cfg = write(d, "c.toml", "[som]\nrows = 10\nneighborhood = \"gaussian\"\n")
            r = run("train", "--config", cfg, "--out", os.path.join(d, "m.json"))
            self.assertEqual(r.returncode, 78)
            self.assertIn("key 'som.neighborhood': unknown key", r.stderr)
            self.assertFalse(os.path.exists(os.path.join(d, "m.json")))

    def test_exit_codes_follow_the_readme_table(self):
        with open(os.path.join(ROOT, "README.md"), encoding="utf-8") as f:
            readme = f.read()
        table = readme[readme.index("## Exit codes"):]
        table = table[:table.index("\n## ")]
        codes = {int(c) for c in re.findall(r"^\| (\d+) \|", table, re.M)}
        with open(os.path.join(ROOT, "core", "exit_codes.hpp"), encoding="utf-8") as f:
            header = {int(c) for c in re.findall(r"= (\d+);", f.read())}
        self.assertEqual(codes, header | {0}, "README table and core/exit_codes.hpp differ")
        curve = os.path.join(CURVES, "roller_car_1bar.csv")
        log = os.path.join(ROOT, "data", "recorded", "roller_1p0bar_fast.log")
        bench = os.path.join(ROOT, "data", "recorded", "roller_1p0bar_fast.bench.toml")
        with tempfile.TemporaryDirectory() as d:
            blocker = write(d, "a_file", "x")
            cases = {
                0: [("--version",)],
                64: [("fit", "--method", "magic", curve), ("fit", "--no-such-option", curve),
                     ("compare", log, log, log), ("replay",)],
                65: [("fit", write(d, "bad.csv", "slip,force_n\n0.1,x\n"))],
                66: [("fit", os.path.join(d, "missing.csv"))],
                73: [("replay", "--report", os.path.join(blocker, "report"), log),
                     ("fit", "--plot", os.path.join(blocker, "p.svg"), curve)],
                78: [("train", "--config", write(d, "c.toml", "[som]\nrows = -1\n"),
                      "--out", os.path.join(d, "m.json"))],
            }
            for code, commands in cases.items():
                for args in commands:
                    r = run(*args)
                    self.assertEqual(r.returncode, code, f"{args}: {r.stderr}")
                    if code:
                        self.assertNotIn("internal error", r.stderr, args)
            # A log cut mid-frame at a byte boundary, and an empty log: done, with a warning
            # and a count.
            with open(log, encoding="utf-8") as f:
                text = f.read()
            cut = write(d, "cut.log", text[: text.index("\n", len(text) // 2) + 34])
            r = run("replay", "--bench", bench, cut)
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertIn("the last line has no newline: the log was cut", r.stderr)
            self.assertRegex(r.stderr, r"1 frame\(s\) shorter than their message ignored")
            empty = write(d, "empty.log", "")
            r = run("replay", "--bench", bench, empty)
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertIn("no CAN frames in the log", r.stderr)


def svg_series(path):
    root = ET.parse(path).getroot()  # raises on malformed XML
    assert root.tag == SVG + "svg"
    return root, [g.get("data-name") for g in root.iter(SVG + "g") if g.get("class") == "series"]


class Plots(unittest.TestCase):
    def test_fit_plot_is_well_formed_with_expected_series(self):
        with tempfile.TemporaryDirectory() as d:
            out = os.path.join(d, "fit.svg")
            r = run("fit", "--slip-unit", "percent", "--plot", out, os.path.join(CURVES, "roller_car_1bar.csv"))
            self.assertEqual(r.returncode, 0, r.stderr)
            root, series = svg_series(out)
            self.assertEqual(series[0], "measured")
            self.assertEqual([s.split(" ")[0] for s in series[1:]], ["som", "mlp", "lm", "hybrid"])
            texts = {t.get("class"): "".join(t.itertext()) for t in root.iter(SVG + "text") if t.get("class")}
            self.assertEqual(texts["x-label"], "slip [%]")
            self.assertEqual(texts["y-label"], "brake force [N]")
            legend = [g for g in root.iter(SVG + "g") if g.get("class") == "legend"][0]
            self.assertEqual(len(list(legend.iter(SVG + "text"))), 5)
            measured = [g for g in root.iter(SVG + "g") if g.get("data-name") == "measured"][0]
            self.assertEqual(len(list(measured.iter(SVG + "circle"))), 150)

    def test_batch_plots_one_file_per_curve(self):
        with tempfile.TemporaryDirectory() as d:
            out = os.path.join(d, "fit.svg")
            r = run("fit", "--method", "lm", "--plot", out, os.path.join(CURVES, "roller_car_1bar.csv"),
                    os.path.join(CURVES, "truck_nominal.csv"))
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertEqual(sorted(os.listdir(d)), ["fit-roller_car_1bar.svg", "fit-truck_nominal.svg"])

    def test_som_map(self):
        with tempfile.TemporaryDirectory() as d:
            out = os.path.join(d, "map.svg")
            r = run("map", "--svg", out, os.path.join(CURVES, "ground_car_1bar.csv"))
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertRegex(r.stdout, r"BMU unit \d+")
            root, series = svg_series(out)
            self.assertEqual(series, ["units", "bmu"])
            units = [p for p in root.iter(SVG + "polygon") if p.get("class") == "unit"]
            self.assertEqual(len(units), 100)
            self.assertEqual(sum(int(p.get("data-hits")) for p in units), 2000)
            bmu = int(re.search(r"BMU unit (\d+)", r.stdout).group(1))
            marked = [c for c in root.iter(SVG + "circle") if c.get("data-unit")][0]
            self.assertEqual(int(marked.get("data-unit")), bmu)


class TrainAndSynth(unittest.TestCase):
    def test_small_training_run_then_fit_with_it(self):
        with tempfile.TemporaryDirectory() as d:
            cfg = write(d, "c.toml", "[database]\ncurves = 200\n[som]\nrows = 4\ncols = 5\nrough_epochs = 20\n"
                        "fine_epochs = 10\n[mlp]\nhidden = [6]\nmax_epochs = 30\n")
            model = os.path.join(d, "m.json")
            r = run("train", "--config", cfg, "--out", model)
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertIn("som-rough", r.stderr)  # progress is shown
            curve = os.path.join(d, "c.csv")
            r = run("synth", "--B", "12", "--C", "1.58", "--D", "3000", "--E", "0.1", "--noise", "0", "--out", curve)
            self.assertEqual(r.returncode, 0, r.stderr)
            r = run("fit", "--model", model, "--method", "hybrid", "--json", curve)
            self.assertEqual(r.returncode, 0, r.stderr)
            res = json.loads(r.stdout)["results"][0]
            self.assertAlmostEqual(res["B"], 12.0, delta=1e-3)
            self.assertAlmostEqual(res["D"], 3000.0, delta=0.5)
            # The map picture of a 4x5 model has 20 units.
            out = os.path.join(d, "map.svg")
            self.assertEqual(run("map", "--model", model, "--svg", out).returncode, 0)
            _, series = svg_series(out)
            self.assertEqual(series, ["units"])


@unittest.skipUnless(os.environ.get("BRAKEFIT_ACCURACY_BIN"), "accuracy bench not built")
class AccuracyBenchSmoke(unittest.TestCase):
    def test_quick_run_prints_all_tables(self):
        r = subprocess.run([os.environ["BRAKEFIT_ACCURACY_BIN"], "--curves", "12", "--random-starts", "2"],
                           capture_output=True, text=True, timeout=300)
        self.assertEqual(r.returncode, 0, r.stderr)
        for title in ("Noise-free, slip 0-100 %", "0-27 %", "Noisy", "Noise floor and convergence"):
            self.assertIn(title, r.stdout)
        rows = [l for l in r.stdout.splitlines() if l.startswith("| hybrid |")]
        self.assertEqual(len(rows), 3)


if __name__ == "__main__":
    unittest.main()


class Scripts(unittest.TestCase):
    """scripts/deps.sh: never upgrades, and without root installs nothing and says what to run."""

    def deps(self, extra_package=None):
        with tempfile.TemporaryDirectory() as d:
            os.chmod(d, 0o755)
            script = os.path.join(d, "deps.sh")
            with open(os.path.join(ROOT, "scripts", "deps.sh"), encoding="utf-8") as f:
                text = f.read()
            if extra_package:
                text = text.replace("BRAKEFIT_TEST_DEBS=(", f"BRAKEFIT_TEST_DEBS=({extra_package} ")
            with open(script, "w", encoding="utf-8") as f:
                f.write(text)
            os.chmod(script, 0o644)
            cmd = ["bash", "-c", f"source {script}; brakefit_install_deps test"]
            if os.getuid() == 0:  # run it as nobody, as a non-root user would
                cmd = ["setpriv", "--reuid=nobody", "--regid=nogroup", "--clear-groups"] + cmd
            return subprocess.run(cmd, capture_output=True, text=True, timeout=60)

    def test_non_root_with_everything_present_needs_nothing(self):
        r = self.deps()
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual(r.stdout + r.stderr, "")

    def test_non_root_with_a_package_missing_says_what_to_run_as_root(self):
        r = self.deps("brakefit-no-such-package")
        self.assertEqual(r.returncode, 1)
        self.assertNotIn("installing", r.stdout + r.stderr)
        self.assertIn("as root, run: apt-get install --no-install-recommends --no-upgrade "
                      "brakefit-no-such-package", r.stderr)

    def test_installs_never_upgrade(self):
        with open(os.path.join(ROOT, "scripts", "deps.sh"), encoding="utf-8") as f:
            text = f.read()
        installs = re.findall(r"apt-get install[^\n]*", text)
        self.assertTrue(installs)
        for line in installs:
            self.assertIn("--no-upgrade", line)

