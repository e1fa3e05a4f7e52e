#!/usr/bin/env python3
"""Per-event fits on the instrument's and on the tyre's basis, against the truth.

    bench/tyre_basis.py [--build build/release] [--b-sets 50]
    /usr/bin/python3 bench/tyre_basis.py --gen-c ../shared/gapgen/gen_c.py --c-sets 12
      (generator C imports numpy: Debian's python3-numpy, under /usr/bin/python3)

1. The shipped recordings (data/recorded, each with its .truth.json): for each bench and tyre
   pressure, `brakefit gap --bench-model` on its three runs writes the bench's measurement model
   (on the ground with the car declared: --vehicle-mass, --cg-height, --wheelbase from the
   recording's scenario, so the vehicle's load transfer is undone as well);
   `brakefit replay --bench-model` then fits every run with it. The model comes from the same
   runs ("same") and from the bench's runs at the other tyre pressure ("other": the bench's
   effects measured on runs the event was not among).
2. Generator B (sim/second, through build/release/bench/second_sim, when --b-sets is given):
   sets of three runs with one instrument effect each at the referee's magnitudes (roller:
   relaxation, time offset, brake threshold, slip offset, wheel inertia; ground: wheel inertia,
   brake threshold, relaxation), the model from a second set (another tyre, load and export) of
   the same bench, effect and magnitude; the truth is the set's tyre at its load and pressure.
3. Generator C (outside the project, when --gen-c is given): sets of three runs with one
   instrument effect each (relaxation, time offset, brake threshold, slip offset, wheel inertia),
   the model from a second set of the same bench and effect, applied to the first.
For each event and method: the fitted curve's RMS distance from the true curve over the event's
slip range (0 to its largest slip), in % of the true peak; raw (instrument) and tyre basis.
Target: the tyre's curve within 2 % of the peak. Prints tables and a brakefit.tyre_basis/1 JSON.
"""
import argparse
import importlib.util
import json
import math
import os
import statistics
import subprocess
import sys
import tempfile
import tomllib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
REC = os.path.join(ROOT, "data", "recorded")
METHODS = ("som", "mlp", "lm", "hybrid")


def log(msg):
    print(f"[tyre_basis] {msg}", file=sys.stderr, flush=True)


def pac96(p, s):
    x = p["B"] * s
    return p["D"] * math.sin(p["C"] * math.atan(x - p["E"] * (x - math.atan(x))))


def rms_pct_peak(fit, truth_force, max_slip):
    """RMS of fit - truth over 200 slips in [0, max_slip], in % of the truth's peak."""
    slips = [max_slip * k / 199 for k in range(200)]
    true = [truth_force(s) for s in slips]
    peak = max(truth_force(k / 1000) for k in range(1001))
    sq = [(pac96(fit, s) - t) ** 2 for s, t in zip(slips, true)]
    return 100 * math.sqrt(sum(sq) / len(sq)) / peak


def run(cmd):
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed ({p.returncode}): {p.stderr[-1500:]}")
    return p.stdout


def bench_model(brakefit, files, out, vehicle=()):
    run([brakefit, "gap", "--bench-model", out, *vehicle, *files])
    return out


def declared_vehicle(log):
    """A ground recording's vehicle (--vehicle-mass, --cg-height, --wheelbase) from the scenario
    its .truth.json carries: a researcher testing on the ground knows the car."""
    scenario = tomllib.loads(json.load(open(log[:-4] + ".truth.json"))["scenario_toml"])
    g = scenario["ground"]
    return ("--vehicle-mass", str(g["vehicle_mass_kg"]), "--cg-height", str(g["cg_height_m"]),
            "--wheelbase", str(g["wheelbase_m"]))


def replay(brakefit, files, model):
    docs = []
    for line in run([brakefit, "replay", "--json", "--bench-model", model, *files]).splitlines():
        if line.strip():
            docs.append(json.loads(line))
    return docs


def score(doc, truth_force):
    """{basis: {method: rms % of peak}} for one event over the slip range the tyre was measured
    on (the event's up to the lock-up runaway or a locked wheel), and (basis_event) over the
    event's whole slip range, past the runaway too."""
    out = {"instrument": {}, "tyre": {}, "instrument_event": {}, "tyre_event": {}, "flagged": {}}
    slip = doc.get("tyre_max_slip_ratio") or doc["max_slip_ratio"]
    out["slip_range"] = slip
    out["event_slip_range"] = doc["max_slip_ratio"]
    for key, basis in (("results", "instrument"), ("tyre_results", "tyre")):
        for r in doc.get(key, []):
            out[basis][r["method"]] = rms_pct_peak(r, truth_force, slip)
            # A result flagged implausible (an MLP extrapolating, a parameter at its bound...)
            # is shown with its reason, never as a plain result.
            out["flagged"][f"{basis} {r['method']}"] = bool(r.get("implausible"))
            out[basis + "_event"][r["method"]] = rms_pct_peak(r, truth_force,
                                                              doc["max_slip_ratio"])
    return out


def recordings(brakefit, tmp):
    groups = {}
    for name in sorted(os.listdir(REC)):
        if name.endswith(".log"):
            bench, pressure = name.split("_")[:2]
            groups.setdefault((bench, pressure), []).append(os.path.join(REC, name))
    models = {k: bench_model(brakefit, v, os.path.join(tmp, f"{k[0]}_{k[1]}.toml"),
                             declared_vehicle(v[0]) if k[0] == "ground" else ())
              for k, v in groups.items()}
    rows = []
    for (bench, pressure), files in groups.items():
        other = next(p for (b, p) in groups if b == bench and p != pressure)
        for source, model in (("same", models[(bench, pressure)]), ("other", models[(bench, other)])):
            for f, doc in zip(files, replay(brakefit, files, model)):
                truth = json.load(open(f[:-4] + ".truth.json"))["pac96_equivalent"]
                rows.append({"set": os.path.basename(f)[:-4], "model": source, "bench": bench,
                             "notes": doc.get("tyre_notes", []),
                             **score(doc, lambda s, t=truth: pac96(t, s))})
    return rows


# The referee's ranges (sim/referee.cpp) for the instrument effects a bench model holds.
B_EFFECTS = [("roller", "relaxation_length", 0.05, 0.4), ("roller", "time_offset", 0.01, 0.05),
             ("roller", "brake_threshold", 1.0, 5.0), ("roller", "slip_offset", 0.002, 0.01),
             ("roller", "wheel_inertia", 0.5, 3.0), ("ground", "wheel_inertia", 0.5, 3.0),
             ("ground", "brake_threshold", 1.0, 5.0), ("ground", "relaxation_length", 0.1, 0.5)]


def truth_curve(path):
    """The tyre's curve from second_sim --truth-curve (slip 0 to 1 in steps of 0.001)."""
    with open(path) as f:
        force = [float(ln.split(",")[1]) for ln in f.read().splitlines()[1:]]
    def at(s):
        x = min(max(s, 0.0), 1.0) * 1000
        i = min(int(x), 999)
        return force[i] + (x - i) * (force[i + 1] - force[i])
    return at


def generator_b(brakefit, second_sim, n_sets, tmp):
    import random
    rng = random.Random(36)
    rows = []
    for k in range(n_sets):
        bench, effect, lo, hi = B_EFFECTS[k % len(B_EFFECTS)]
        mag = rng.uniform(lo, hi)
        seed = 7000 + k
        dirs = []
        for j, s in enumerate((seed, seed + 50000)):
            d = os.path.join(tmp, f"b{k}_{j}")
            run([second_sim, "--bench", bench, "--effect", effect, "--magnitude", repr(mag),
                 "--seed", str(s), "--truth-curve", os.path.join(tmp, f"b{k}_{j}.truth.csv"),
                 "--out", d])
            dirs.append(d)
        files = [os.path.join(dirs[0], f"{bench}-{effect}-{i}.csv") for i in range(3)]
        model = bench_model(brakefit,
                            [os.path.join(dirs[1], f"{bench}-{effect}-{i}.csv") for i in range(3)],
                            os.path.join(tmp, f"b{k}.toml"))
        truth = truth_curve(os.path.join(tmp, f"b{k}_0.truth.csv"))
        for i, doc in enumerate(replay(brakefit, files, model)):
            rows.append({"set": f"B {bench} {effect} {mag:.3g} seed {seed} run {i}",
                         "model": "other set", "bench": bench,
                         "notes": doc.get("tyre_notes", []), **score(doc, truth)})
        log(f"generator B set {k + 1}/{n_sets}")
    return rows


def generator_c(brakefit, script, n_sets, tmp):
    spec = importlib.util.spec_from_file_location("gen_c", script)
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    effects = [("roller", "relaxation_length"), ("roller", "time_offset"),
               ("roller", "brake_threshold"), ("roller", "slip_offset"),
               ("ground", "wheel_inertia"), ("ground", "brake_threshold")]
    rows = []
    for k in range(n_sets):
        bench, effect = effects[k % len(effects)]
        seed = 9000 + k
        sets = []
        for j, s in enumerate((seed, seed + 50000)):
            d = os.path.join(tmp, f"c{k}_{j}")
            run(["/usr/bin/python3", script, d, "--bench", bench, "--effect", effect, "--seed",
                 str(s)])
            sets.append(d)
        # The model from the second set (another draw: its own tyre, load and magnitude... the
        # bench's effect drawn again), so it is measured on runs the events were not among: the
        # second set takes the first's magnitude.
        mag = json.load(open(os.path.join(sets[0], "truth.json")))["magnitude"]
        run(["/usr/bin/python3", script, sets[1], "--bench", bench, "--effect", effect, "--seed",
             str(seed + 50000), "--magnitude", repr(mag)])
        files = [os.path.join(sets[0], f"run{i}.csv") for i in range(3)]
        model = bench_model(brakefit, [os.path.join(sets[1], f"run{i}.csv") for i in range(3)],
                            os.path.join(tmp, f"c{k}.toml"))
        truth = json.load(open(os.path.join(sets[0], "truth.json")))
        tyre = gen.TYRES[truth["tyre"]]
        for i, doc in enumerate(replay(brakefit, files, model)):
            fz = float(open(files[i]).read().split("wheel_load_n=")[1].split()[0])
            rows.append({"set": f"C {bench} {effect} seed {seed} run {i}", "model": "other set",
                         "bench": bench,
                         "notes": doc.get("tyre_notes", []),
                         **score(doc, lambda s, t=tyre, z=fz: float(gen.tyre_force(t, s, z)))})
        log(f"generator C set {k + 1}/{n_sets}")
    return rows


def table(title, rows, suffix=""):
    print(f"\n## {title}\n")
    print("| set | model | slip range % | " + " | ".join(f"{m} raw | {m} tyre" for m in METHODS)
          + " |")
    print("|---|---|---|" + "---|" * (2 * len(METHODS)))
    for r in rows:
        cells = []
        for m in METHODS:
            for basis in ("instrument", "tyre"):
                v = r[basis + suffix].get(m)
                flag = "*" if r["flagged"].get(f"{basis} {m}") else ""
                cells.append("-" if v is None else f"{v:.2f}{flag}")
        rng = r["event_slip_range" if suffix else "slip_range"]
        print(f"| {r['set']} | {r['model']} | {100 * rng:.1f} | " + " | ".join(cells) + " |")
    summary = {}
    for bench in sorted({r["bench"] for r in rows}):
        print(f"\n{bench}:")
        for m in METHODS:
            for basis in ("instrument", "tyre"):
                mine = [r for r in rows if r["bench"] == bench and m in r[basis + suffix]]
                v = [r[basis + suffix][m] for r in mine]
                if v:
                    within = sum(x <= 2.0 for x in v)
                    silent = sum(r[basis + suffix][m] > 2.0 and not r["flagged"].get(f"{basis} {m}")
                                 for r in mine)
                    summary[f"{bench}_{m}_{basis}"] = {
                        "median": statistics.median(v), "max": max(v), "within_2pct": within,
                        "over_2pct_unflagged": silent, "events": len(v)}
                    print(f"{m:>7} {basis:<10}: median {statistics.median(v):6.2f} %, max "
                          f"{max(v):6.2f} %, within 2 %: {within}/{len(v)}, over 2 % without a "
                          f"flag: {silent}")
    return summary


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build", "release"))
    ap.add_argument("--gen-c", default=None, help="generator C's script (outside the project)")
    ap.add_argument("--c-sets", type=int, default=12)
    ap.add_argument("--b-sets", type=int, default=0, help="generator B sets (0: none)")
    a = ap.parse_args()
    brakefit = os.path.join(a.build, "cli", "brakefit")
    commit = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"],
                            capture_output=True, text=True).stdout.strip()
    args = (f" --b-sets {a.b_sets}" if a.b_sets else "") + (
        f" --gen-c {a.gen_c} --c-sets {a.c_sets}" if a.gen_c else "")
    print(f"# bench/tyre_basis.py{args}   (commit {commit})")
    print("RMS distance of each fitted curve from the true curve over the event's slip range, "
          "% of the true peak (raw: the instrument's force; tyre: the bench model's effects "
          "undone; * the result carries an implausibility flag with its reason, as every output "
          "shows it)")
    doc = {"schema": "brakefit.tyre_basis", "version": 1, "commit": commit}
    with tempfile.TemporaryDirectory() as tmp:
        rec = recordings(brakefit, tmp)
        doc["recordings"] = {
            "rows": rec, "summary": table("Shipped recordings, over the slip the tyre was measured on", rec),
            "summary_event": table("Shipped recordings, over the event's whole slip range", rec,
                                   "_event")}
        if a.b_sets:
            b = generator_b(brakefit, os.path.join(a.build, "bench", "second_sim"), a.b_sets, tmp)
            doc["generator_b"] = {"rows": b, "summary": table("Generator B", b)}
        if a.gen_c:
            c = generator_c(brakefit, a.gen_c, a.c_sets, tmp)
            doc["generator_c"] = {"rows": c, "summary": table("Generator C", c)}
    print(json.dumps(doc))


if __name__ == "__main__":
    main()
