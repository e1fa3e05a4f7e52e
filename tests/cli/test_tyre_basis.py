"""The bench's measurement model (issue 36): `gap --bench-model` writes the instrument effects it
named; `replay --bench-model` and brakefitd's `[bench] measurement_model` fit each event again
with them undone, and every result says its basis. On the shipped roller recordings the tyre's
curve comes within 2 % of the truth's peak where the instrument's does not."""
import json
import math
import os
import re
import subprocess
import tempfile
import unittest

from test_cli import ROOT, run

REC = os.path.join(ROOT, "data", "recorded")
BRAKEFITD = os.environ.get("BRAKEFITD_BIN", os.path.join(ROOT, "build", "release", "daemon",
                                                         "brakefitd"))


def pac96(p, s):
    x = p["B"] * s
    return p["D"] * math.sin(p["C"] * math.atan(x - p["E"] * (x - math.atan(x))))


def rms_pct_peak(fit, truth, max_slip):
    slips = [max_slip * k / 199 for k in range(200)]
    peak = max(pac96(truth, k / 1000) for k in range(1001))
    sq = [(pac96(fit, s) - pac96(truth, s)) ** 2 for s in slips]
    return 100 * math.sqrt(sum(sq) / len(sq)) / peak


def cut_at_slip(lines, max_slip):
    """An event CSV's lines (comments, header, samples) up to the first sample whose measured slip
    (1 - v_wheel / v_ref) reaches max_slip."""
    out = []
    for ln in lines:
        if ln.startswith("#") or ln.startswith("t_s"):
            out.append(ln)
            continue
        v_ref, v_wheel = (float(x) for x in ln.split(",")[1:3])
        if v_ref > 0 and 1 - v_wheel / v_ref >= max_slip:
            break
        out.append(ln)
    return out


def by_method(doc, log, methods=("lm", "hybrid")):
    """{method: (raw result, tyre result, raw % of peak, tyre % of peak)} against the log's truth,
    over the slip the tyre was measured on."""
    with open(log[:-4] + ".truth.json") as f:
        truth = json.load(f)["pac96_equivalent"]
    slip = doc["tyre_max_slip_ratio"]
    out = {}
    for method in methods:
        raw = next(x for x in doc["results"] if x["method"] == method)
        tyre = next(x for x in doc["tyre_results"] if x["method"] == method)
        out[method] = (raw, tyre, rms_pct_peak(raw, truth, slip), rms_pct_peak(tyre, truth, slip))
    return out


class TyreBasis(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.model = os.path.join(cls.tmp.name, "roller.toml")
        runs = [os.path.join(REC, f"roller_2p2bar_{r}.log") for r in ("slow", "medium", "fast")]
        r = run("gap", "--bench-model", cls.model, *runs)
        assert r.returncode == 0, r.stderr
        cls.gap_stderr = r.stderr

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_the_model_holds_the_instruments_effects_with_their_errors(self):
        with open(self.model) as f:
            text = f.read()
        self.assertIn('schema = "brakefit.bench_model"', text)
        self.assertIn('condition = "roller"', text)
        self.assertIn("# model hash sha256:", text)
        self.assertIn("roller_2p2bar_fast.log", text)
        for table, key in (("relaxation_length", "sigma_m"), ("brake_threshold", "p0_bar"),
                           ("wheel_inertia", "inertia_kgm2")):
            self.assertIn(f"[effects.{table}]\n{key} = ", text)
            self.assertIn(f"{key}_stderr = ", text)
        self.assertIn("bench model written to", self.gap_stderr)

    def test_replay_fits_the_tyre_within_two_percent_of_its_peak(self):
        # The model from the 2.2 bar runs, applied to the 1.0 bar runs it never saw.
        for ramp in ("slow", "medium", "fast"):
            log = os.path.join(REC, f"roller_1p0bar_{ramp}.log")
            r = run("replay", "--json", "--bench-model", self.model, log)
            self.assertEqual(r.returncode, 0, r.stderr)
            doc = json.loads(r.stdout.splitlines()[0])
            self.assertEqual({x["basis"] for x in doc["results"]}, {"instrument"})
            self.assertEqual([x["basis"] for x in doc["tyre_results"]], ["tyre"] * 4)
            self.assertEqual([x["method"] for x in doc["tyre_results"]],
                             [x["method"] for x in doc["results"]])
            # The tyre's own (transient) slip: behind the wheel's past the peak, as the
            # relaxation lags it.
            slip = doc["tyre_max_slip_ratio"]
            self.assertGreater(slip, 0.08)
            self.assertLess(slip, doc["max_slip_ratio"])
            for method, (raw, tyre, raw_pct, tyre_pct) in by_method(doc, log).items():
                self.assertLess(tyre_pct, 2.0, (ramp, method, tyre))
                self.assertGreater(raw_pct, 1.5, (ramp, method, raw))
        r = run("replay", "--bench-model", self.model, os.path.join(REC, "roller_1p0bar_slow.log"))
        self.assertIn("the tyre's curve (the bench model's ", r.stdout)

    def test_a_roller_model_is_not_applied_to_a_ground_event(self):
        r = run("replay", "--json", "--bench-model", self.model,
                os.path.join(REC, "ground_2p2bar_150barps.log"))
        self.assertEqual(r.returncode, 0, r.stderr)
        doc = json.loads(r.stdout.splitlines()[0])
        self.assertEqual(doc["tyre_results"], [])
        self.assertIn("is of a roller bench and this event of a ground bench", doc["tyre_notes"][0])

    def ground_fits(self, model, pressure):
        """(ramp, method, by_method's tuple) for each shipped ground run at the tyre pressure
        ("1p0", "2p2"), replayed with the bench model."""
        out = []
        for ramp in (100, 150, 250):
            log = os.path.join(REC, f"ground_{pressure}bar_{ramp}barps.log")
            r = run("replay", "--json", "--bench-model", model, log)
            self.assertEqual(r.returncode, 0, r.stderr)
            doc = json.loads(r.stdout.splitlines()[0])
            out += [(ramp, m, v) for m, v in by_method(doc, log).items()]
        return out

    def test_a_ground_model_with_the_car_declared_fits_the_tyre_at_its_static_load(self):
        # The car's load transfer (its mass, centre of gravity and wheelbase, as the recordings'
        # scenario has them) is undone with the bench's effects: the model from the 2.2 bar runs,
        # applied to the 1.0 bar runs it never saw, gives the tyre at its 3 800 N.
        model = os.path.join(self.tmp.name, "ground.toml")
        car = ("--vehicle-mass", "1300", "--cg-height", "0.55", "--wheelbase", "2.6")
        runs = [os.path.join(REC, f"ground_2p2bar_{r}barps.log") for r in (100, 150, 250)]
        r = run("gap", "--bench-model", model, *car, *runs)
        self.assertEqual(r.returncode, 0, r.stderr)
        with open(model) as f:
            text = f.read()
        self.assertIn("# declared from the vehicle: 1300 kg", text)
        self.assertIn("[effects.load_transfer]\ndfz_per_decel_s2_per_m = 0.0336", text)
        self.assertIn("not_held = []", text)
        for ramp, method, (raw, tyre, raw_pct, tyre_pct) in self.ground_fits(model, "1p0"):
            self.assertLess(tyre_pct, 2.0, (ramp, method, tyre))
            self.assertGreater(raw_pct, 20.0, (ramp, method, raw))
            self.assertEqual(tyre["implausible"], [], (ramp, method, tyre))
        # The geometry belongs to a ground test, and comes whole.
        roller = [os.path.join(REC, "roller_2p2bar_slow.log")] * 2
        r = run("gap", "--bench-model", model, *car, *roller)
        self.assertEqual(r.returncode, 64, r.stderr)
        self.assertIn("from a roller, which has no load transfer", r.stderr)
        r = run("gap", "--bench-model", model, "--cg-height", "0.55", *runs)
        self.assertEqual(r.returncode, 64, r.stderr)
        self.assertIn("needs --vehicle-mass, --cg-height and --wheelbase together", r.stderr)

    def test_a_declared_car_is_held_in_the_diagnosis(self):
        # Declared, the car's load transfer is held in every fit of the diagnosis rather than
        # shared out among the instrument's effects it resembles: on the 1.0 bar ground runs the
        # wheel's inertia is then named (unheld it is not), and the model from these runs gives
        # the 2.2 bar runs' tyre within 2.5 % of its peak (it names the car's speed friction and
        # leaves its 0.5 bar threshold in the gap: the fastest ramp's peak is 2.1 % off).
        car = ("--vehicle-mass", "1300", "--cg-height", "0.55", "--wheelbase", "2.6")
        runs = [os.path.join(REC, f"ground_1p0bar_{r}barps.log") for r in (100, 150, 250)]
        model = os.path.join(self.tmp.name, "ground_1p0.toml")
        verdicts = {}
        for declared in (False, True):
            args = ("--bench-model", model, *car) if declared else ()
            r = run("gap", *args, *runs)
            self.assertEqual(r.returncode, 0, r.stderr)
            verdicts[declared] = re.search(r"^verdict: (.*)$", r.stdout, re.M).group(1)
            self.assertEqual("load transfer declared from the vehicle" in r.stdout, declared)
        self.assertNotIn("wheel_inertia", verdicts[False])
        self.assertIn("wheel_inertia", verdicts[True])
        self.assertNotIn("load_transfer", verdicts[True])  # held, not a candidate
        for ramp, method, (_, tyre, _, tyre_pct) in self.ground_fits(model, "2p2"):
            self.assertLess(tyre_pct, 2.5, (ramp, method, tyre))

    def test_bad_and_missing_models(self):
        log = os.path.join(REC, "roller_1p0bar_slow.log")
        bad = os.path.join(self.tmp.name, "bad.toml")
        with open(bad, "w") as f:
            f.write('schema = "brakefit.bench_model"\nversion = 1\ncondition = "roller"\n'
                    "[effects.wheel_inertia]\ninertia_kg = 0.7\n")
        r = run("replay", "--bench-model", bad, log)
        self.assertEqual(r.returncode, 65, r.stderr)
        self.assertIn(f"{bad}: key 'effects.wheel_inertia.inertia_kg'", r.stderr)
        r = run("replay", "--bench-model", os.path.join(self.tmp.name, "nosuch.toml"), log)
        self.assertEqual(r.returncode, 66, r.stderr)

    def test_brakefitd_publishes_the_tyres_fits_from_its_bench_model(self):
        d = self.tmp.name
        cfg = os.path.join(d, "d.toml")
        with open(os.path.join(ROOT, "config", "examples", "replay.toml")) as f:
            text = f.read()
        text = text.replace('"data/', f'"{ROOT}/data/').replace("out/daemon/events.db",
                                                               os.path.join(d, "events.db"))
        text = text.replace("port = 1502", "port = 0")
        with open(cfg, "w") as f:
            f.write(text.replace("switch_off_slip_ratio = 0.27",
                                 f'switch_off_slip_ratio = 0.27\nmeasurement_model = "{self.model}"'))
        p = subprocess.run([BRAKEFITD, "--config", cfg], capture_output=True, text=True,
                           timeout=120)
        self.assertEqual(p.returncode, 0, p.stderr)
        self.assertIn("(tyre basis)", p.stderr)
        r = run("events", "--db", os.path.join(d, "events.db"), "list")
        self.assertIn("(tyre)", r.stdout)
        # A ground model on a roller bench is refused at --check, naming the key.
        ground = os.path.join(d, "ground.toml")
        with open(self.model) as f:
            model = f.read()
        with open(ground, "w") as f:
            f.write(model.replace('condition = "roller"', 'condition = "ground"'))
        with open(cfg, "w") as f:
            f.write(text.replace("switch_off_slip_ratio = 0.27",
                                 f'switch_off_slip_ratio = 0.27\nmeasurement_model = "{ground}"'))
        p = subprocess.run([BRAKEFITD, "--check", "--config", cfg], capture_output=True, text=True,
                           timeout=60)
        self.assertEqual(p.returncode, 78, p.stderr)
        self.assertIn("key 'bench.measurement_model'", p.stderr)


    def test_the_shipped_model_is_what_gap_writes_today(self):
        # data/bench_models/make.sh writes it from the same three runs as setUpClass.
        def values(path):
            with open(path) as f:
                return {ln.split(" = ")[0]: float(ln.split(" = ")[1]) for ln in f
                        if re.match(r"^[a-z0-9_]+ = [-0-9.e]+$", ln.strip())
                        and not ln.startswith("version")}
        shipped = values(os.path.join(ROOT, "data", "bench_models", "roller.bench.toml"))
        fresh = values(self.model)
        self.assertEqual(sorted(shipped), sorted(fresh))
        self.assertGreaterEqual(len(fresh), 6, fresh)
        for key, v in fresh.items():
            self.assertAlmostEqual(shipped[key], v, delta=1e-6 * max(1.0, abs(v)), msg=key)

    def test_fit_undoes_the_model_on_an_exported_event(self):
        events = os.path.join(self.tmp.name, "events")
        log = os.path.join(REC, "roller_1p0bar_fast.log")
        r = run("export", log, "--events", events)
        self.assertEqual(r.returncode, 0, r.stderr)
        csv = os.path.join(events, "roller_1p0bar_fast-event-1.csv")
        r = run("fit", "--json", "--bench-model", self.model, csv)
        self.assertEqual(r.returncode, 0, r.stderr)
        doc = json.loads(r.stdout.splitlines()[0])
        self.assertEqual(doc["schema"], "brakefit.event/1")
        methods = ("mlp", "lm", "hybrid")
        for method, (raw, tyre, raw_pct, tyre_pct) in by_method(doc, log, methods).items():
            self.assertEqual((raw["basis"], tyre["basis"]), ("instrument", "tyre"))
            self.assertLess(tyre_pct, 2.0, (method, tyre))
            self.assertGreater(raw_pct, 5.0, (method, raw))
        # The tyre's curve ends short of the switch-off (10 % slip here), and the shipped MLP was
        # trained on curves cut as short as 4 %: its estimate is a plain result (within 2 %,
        # above), not an extrapolation. Cut shorter than any curve it saw, it is flagged.
        mlp = next(x for x in doc["tyre_results"] if x["method"] == "mlp")
        self.assertEqual(mlp["implausible"], [], mlp)
        r = run("fit", "--bench-model", self.model, csv)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("the tyre's curve (the bench model's ", r.stdout)
        self.assertNotIn("NOT A TYRE'S CURVE", r.stdout.split("the tyre's curve (")[1])
        short = os.path.join(events, "short-event.csv")
        with open(csv) as f:
            lines = f.read().splitlines()
        # The event's samples up to 3.5 % measured slip (the header and comments kept).
        with open(short, "w") as f:
            f.write("\n".join(cut_at_slip(lines, 0.035)) + "\n")
        r = run("fit", "--json", "--bench-model", self.model, short)
        self.assertEqual(r.returncode, 0, r.stderr)
        doc = json.loads(r.stdout.splitlines()[0])
        mlp = next(x for x in doc["tyre_results"] if x["method"] == "mlp")
        self.assertTrue(any("MLP extrapolating" in w for w in mlp["implausible"]), mlp)
        raw_mlp = next(x for x in doc["results"] if x["method"] == "mlp")
        self.assertTrue(any("MLP extrapolating" in w for w in raw_mlp["implausible"]), raw_mlp)
        # A model is for events: with curve CSVs alone it is a usage error that says why.
        curve = os.path.join(ROOT, "data", "curves", "roller_car_1bar.csv")
        r = run("fit", "--bench-model", self.model, curve)
        self.assertEqual(r.returncode, 64, r.stderr)
        self.assertIn("give event CSVs", r.stderr)


if __name__ == "__main__":
    unittest.main()
