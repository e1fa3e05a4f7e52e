#!/usr/bin/env python3
"""Generator C's suite through `brakefit gap`, scored against its truth.

    /usr/bin/python3 bench/gap_c_suite.py [--gen-c ../shared/gapgen/gen_c.py] [--seed 77[,5,...]]
        [--build build/release] [--threads 2] [--tir] [--gap-arg=OPTION ...]
        [--results docs/gap_results.md [--results-key K]]
      (generator C imports numpy: Debian's python3-numpy, under /usr/bin/python3)

Generator C (written outside the project) writes its plan of sets (94 at its default seed, 77):
single effects on the roller and the ground, null sets and misspecified (Burckhardt) tyres, with
OUT/truth.json. Each set's runs go through `brakefit gap --json` with the shipped gates, as a
user would run them. A single effect counts as named when it is the first verdict (on the
roller, where a set's runs share one speed, a lag and a delay count as one); a null set when the
verdict is exactly ["none"]; a misspecified set when its first verdict is `none` or
`unexplained`. A false claim is a catalogue name first on a set without an effect (nulls and
misspecified). Of the single effects named, the table also counts those named alone: no other
catalogue name beside them (on the roller the lag's twin aside; `unexplained` is not a name), and
lists the others as extra names. The magnitude error is the joint model's estimate
(parameters_after) against the truth where the effect is named; load transfer's is the wheel
load's change the report gives (dFz/Fz per m/s^2, the accepted effect's
load_ratio_per_decel_s2_per_m) in C's law's unit, h/L (C's vehicle weighs 3.4 Fz0/g, so dFz/Fz
per m/s^2 is 3.4 h/L / (2 g)). Without the tyre's file the report also reads it at the ends of
the held tyres' laws (docs/gap.md §3): the table counts the sets whose truth lies inside that
band.

With --tir each set is diagnosed as a researcher who knows the tyre would: `brakefit gap --tir`
with the set's tyre's MF 6.1 file, written from generator C's own coefficients (its TYRES table,
read from its script without running it: bench/gen_c_tyres.py); a load transfer is then read
at that tyre's load laws instead of the held tyres'.

Several seeds (--seed 5,11,23): each seed's plan is written and diagnosed, and the table pools
their sets; load transfer's magnitude error is also given per tyre (C's three tyres have their
own load laws). Prints the table, every miss and a brakefit.gap_c_suite/1 JSON; with --results,
writes the table into that file between its `gap_c_suite` markers (`gap_c_suite KEY` with
--results-key), the command and the commit at its head.
"""
import argparse
import concurrent.futures as cf
import datetime
import json
import os
import shlex
import statistics
import subprocess
import sys
import tempfile
import time

from gen_c_tyres import write_all as write_c_tyres
from results_block import source_commit, writable, write_block

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
G_MPS2 = 9.81
C_MASS_PER_LOAD = 3.4  # C's vehicle: mass 3.4 Fz0 / g
LAGS = ("relaxation_length", "time_offset")
PARAM = {
    "relaxation_length": "sigma_m",
    "time_offset": "dt_s",
    "brake_threshold": "p0_bar",
    "slip_offset": "slip_offset_ratio",
    "wheel_inertia": "inertia_kgm2",
    "speed_friction": "lambda_mu_v",
}
NO_EFFECT = ("none", "misspec")


def log(msg):
    print(f"[gap_c_suite] {msg}", file=sys.stderr, flush=True)


def diagnose(brakefit, set_dir, case, tir_dir=None, gap_args=()):
    d = os.path.join(set_dir, case["case"])
    runs = sorted(os.path.join(d, f) for f in os.listdir(d) if f.endswith(".csv"))
    tir = ["--tir", os.path.join(tir_dir, case["tyre"] + ".tir")] if tir_dir and case.get("tyre") else []
    p = subprocess.run([brakefit, "gap", "--json", *gap_args, *tir, *runs], capture_output=True,
                       text=True)
    try:
        return json.loads(p.stdout)
    except json.JSONDecodeError:
        return {"verdict": ["refused"], "error": p.stderr.strip().splitlines()[-1:]}


def own_names(case):
    """The names that count as the set's effect: on the roller, where a set's runs share one
    speed, a lag and a delay count as one."""
    return set(LAGS) if case["bench"] == "roller" and case["effect"] in LAGS else {case["effect"]}


def extra_names(case, verdict):
    """The catalogue names a verdict gives beside the set's effect."""
    own = own_names(case)
    return [v for v in verdict if v not in own and v not in ("none", "unexplained")]


def named_first(case, verdict):
    return bool(verdict) and verdict[0] in own_names(case)


def load_params(doc):
    """The accepted load transfer's parameters as the report gives them ({} where not named)."""
    for e in doc.get("effects") or []:
        if e.get("accepted") and e.get("name") == "load_transfer":
            return e.get("params") or {}
    return {}


def load_ratio(doc):
    """Load transfer's magnitude as the report gives it: the wheel load's relative change per m/s^2
    (dFz/Fz), read with the held tyres' load laws (the accepted effect's load ratio; the model's
    own dfz_per_decel_s2_per_m scales the peak at the stiffness ratio fitted free)."""
    return load_params(doc).get("load_ratio_per_decel_s2_per_m")


def load_band(doc):
    """The load's change read at the ends of the held tyres' load laws, in h/L (low, high), or
    None where the report gives no band (read at the tyre's own file, or not named)."""
    p = load_params(doc)
    lo, hi = (p.get(f"load_ratio_per_decel_{k}_s2_per_m") for k in ("low", "high"))
    if lo is None or hi is None:
        return None
    return lo * 2 * G_MPS2 / C_MASS_PER_LOAD, hi * 2 * G_MPS2 / C_MASS_PER_LOAD


def estimate(case, doc):
    """The joint model's estimate of the case's effect, in the truth's unit (None: not named)."""
    if case["effect"] == "load_transfer":
        v = load_ratio(doc)
        return None if v is None else v * 2 * G_MPS2 / C_MASS_PER_LOAD  # dFz/Fz -> h/L
    after = doc.get("parameters_after") or {}
    name = PARAM.get(case["effect"])
    v = after.get(name) if name else None
    if v is None:
        return None  # not in the model (on the roller the other lag may have been named)
    if case["effect"] == "slip_offset":
        return -v  # C reads the wheel (1 + m) fast: the measured slip is the true one less m
    return v


def score(truth, docs):
    rows = {"single": [0, 0], "alone": [0, 0], "load_transfer": [0, 0], "null": [0, 0],
            "misspec": [0, 0], "false_claims": [0, 0]}
    errors, misses, named, extras = {}, [], [], []
    per_effect, load_by_tyre, band_by_tyre = {}, {}, {}
    for case, doc in zip(truth, docs):
        e, v = case["effect"], doc.get("verdict", [])
        if e == "none":
            ok = v == ["none"]
            rows["null"][0] += ok
            rows["null"][1] += 1
        elif e == "misspec":
            ok = bool(v) and v[0] in ("none", "unexplained")
            rows["misspec"][0] += ok
            rows["misspec"][1] += 1
        else:
            ok = named_first(case, v)
            rows["single"][0] += ok
            rows["single"][1] += 1
            if ok:
                extra = extra_names(case, v)
                rows["alone"][0] += not extra
                rows["alone"][1] += 1
                if extra:
                    extras.append(f"{case['case']} {case['bench']} {e} {case['magnitude']:.4g} "
                                  f"said {v}")
            key = f"{case['bench']} {e}"
            per_effect.setdefault(key, [0, 0])
            per_effect[key][0] += ok
            per_effect[key][1] += 1
            if e == "load_transfer":
                rows["load_transfer"][0] += ok
                rows["load_transfer"][1] += 1
            est = estimate(case, doc) if ok else None
            if est is not None and case["magnitude"] != 0:
                err = abs(est - case["magnitude"]) / abs(case["magnitude"])
                errors.setdefault(e, []).append(err)
                if e == "load_transfer":
                    load_by_tyre.setdefault(case.get("tyre", "?"), []).append(err)
                    if band := load_band(doc):
                        inside = band[0] <= case["magnitude"] <= band[1]
                        counts = band_by_tyre.setdefault(case.get("tyre", "?"), [0, 0])
                        counts[0] += inside
                        counts[1] += 1
                named.append(f"{case['case']} {case['bench']} {e} {est:.4g} for "
                             f"{case['magnitude']:.4g}")
        if e in NO_EFFECT:
            rows["false_claims"][1] += 1
            rows["false_claims"][0] += bool(v) and v[0] not in ("none", "unexplained", "refused")
        if not ok:
            misses.append(f"{case['case']} {case['bench']} {e} {case['magnitude']:.4g} said {v}")
    return rows, per_effect, errors, misses, named, load_by_tyre, band_by_tyre, extras


def pct(a, b):
    return f"{a} of {b} ({100 * a / b:.0f} %)" if b else "–"


def table(rows, per_effect, errors, load_by_tyre, band_by_tyre):
    out = ["| sets | result |", "|---|---|"]
    out.append(f"| single effects named first (lag and delay at one roller speed as one) | "
               f"{pct(*rows['single'])} |")
    out.append(f"| of them named alone (no other catalogue name beside them; on the roller the "
               f"lag's twin aside) | {pct(*rows['alone'])} |")
    for key in sorted(per_effect):
        out.append(f"| {key} | {per_effect[key][0]} of {per_effect[key][1]} |")
    out.append(f"| null sets `[\"none\"]` | {pct(*rows['null'])} |")
    out.append(f"| misspecified (Burckhardt) `none` or `unexplained` | {pct(*rows['misspec'])} |")
    out.append(f"| false claims on the sets without an effect (nulls and misspecified) | "
               f"{pct(*rows['false_claims'])} |")
    med = ", ".join(f"{e} {100 * statistics.median(v):.1f} % ({len(v)})"
                    for e, v in sorted(errors.items()))
    out.append(f"| magnitude error where named, median (sets) | {med} |")
    by_tyre = ", ".join(f"{t} {100 * statistics.median(v):.1f} % ({len(v)})"
                        for t, v in sorted(load_by_tyre.items()))
    out.append(f"| load transfer's error by tyre, median (sets) | {by_tyre or '–'} |")
    inside = [sum(c[0] for c in band_by_tyre.values()), sum(c[1] for c in band_by_tyre.values())]
    band = "; ".join([pct(*inside)] + [f"{t} {c[0]} of {c[1]}" for t, c in sorted(band_by_tyre.items())])
    if not inside[1]:
        band = "– (no band: read at the tyre's own laws)"
    out.append("| load transfer's truth inside the report's band at published tyres' load laws "
               f"(by tyre) | {band} |")
    return "\n".join(out)


def write_results(path, text, key=""):
    write_block(path, f"gap_c_suite {key}" if key else "gap_c_suite", text)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gen-c", default=os.path.join(ROOT, "..", "shared", "gapgen", "gen_c.py"))
    ap.add_argument("--seed", default="77", help="the plan's seed, or several: 5,11,23")
    ap.add_argument("--build", default=os.path.join(ROOT, "build", "release"))
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--set", help="an existing suite directory (gen_c.py OUT) instead of a new one")
    ap.add_argument("--tir", action="store_true",
                    help="give each set its tyre's MF 6.1 file (from generator C's TYRES)")
    ap.add_argument("--results", help="markdown file to write the table into")
    ap.add_argument("--results-key", default="", help="its block's key (several blocks a file)")
    ap.add_argument("--gap-arg", action="append", default=[],
                    help="an option for each `brakefit gap` (--gap-arg=--realign-delay)")
    ap.add_argument("--dry-run", action="store_true",
                    help="check the options and what they name, print the plan, run nothing")
    a = ap.parse_args()
    try:
        seeds = [int(x) for x in a.seed.split(",")]
    except ValueError:
        ap.error(f"--seed takes integers separated by commas, not {a.seed!r}")
    if a.set and len(seeds) > 1:
        ap.error("--set reads one suite: give one seed (or none) with it")
    brakefit = os.path.join(a.build, "cli", "brakefit")
    if not os.access(brakefit, os.X_OK):
        sys.exit(f"gap_c_suite: {brakefit} is not built (--build)")
    if not a.set and not os.path.exists(a.gen_c):
        sys.exit(f"gap_c_suite: generator C's script {a.gen_c} is not there (--gen-c)")
    if a.set and not os.path.exists(os.path.join(a.set, "truth.json")):
        sys.exit(f"gap_c_suite: {a.set} holds no truth.json (--set)")
    if a.results and not writable(a.results):
        sys.exit(f"gap_c_suite: cannot write the results file {a.results}")
    if a.dry_run:
        print(json.dumps({"schema": "brakefit.gap_c_suite_plan/1", "version": "0.1.0",
                          "seeds": seeds, "set": a.set, "tir": a.tir, "results": a.results,
                          "results_key": a.results_key}))
        return
    start = time.time()
    truth, docs = [], []
    with tempfile.TemporaryDirectory(prefix="gap_c_suite-") as tmp:
        tir_dir = None
        if a.tir:
            tir_dir = os.path.join(tmp, "tyres")
            write_c_tyres(a.gen_c, tir_dir)
        for seed in seeds:
            set_dir = a.set or os.path.join(tmp, f"set{seed}")
            if not a.set:
                log(f"writing generator C's suite (seed {seed}) to {set_dir}")
                subprocess.run([sys.executable, a.gen_c, set_dir, "--seed", str(seed)],
                               check=True, stdout=subprocess.DEVNULL)
            with open(os.path.join(set_dir, "truth.json")) as f:
                cases = json.load(f)
            found = [None] * len(cases)
            with cf.ThreadPoolExecutor(a.threads) as ex:
                futures = {ex.submit(diagnose, brakefit, set_dir, c, tir_dir, a.gap_arg): i for i, c in enumerate(cases)}
                for n, fut in enumerate(cf.as_completed(futures), 1):
                    found[futures[fut]] = fut.result()
                    if n % 10 == 0 or n == len(cases):
                        log(f"seed {seed}: {n}/{len(cases)} sets diagnosed")
            for c in cases:
                c["case"] = c["case"] if len(seeds) == 1 else f"seed{seed}/{c['case']}"
            truth += cases
            docs += found
    rows, per_effect, errors, misses, named, load_by_tyre, band_by_tyre, extras = score(truth, docs)
    minutes = (time.time() - start) / 60
    commit = source_commit(ROOT)
    command = shlex.join(["/usr/bin/python3", "bench/gap_c_suite.py"] + sys.argv[1:])
    head = (f"<!-- written by `{command}` at commit {commit} ({datetime.date.today()}, "
            f"{minutes:.0f} min; {len(truth)} sets of generator C, "
            f"seed{'s' if len(seeds) > 1 else ''} {', '.join(map(str, seeds))}) -->")
    text = head + "\n\n" + table(rows, per_effect, errors, load_by_tyre, band_by_tyre)
    print(text)
    print("\nmisses:\n" + "\n".join(misses or ["none"]))
    print("\nnamed with extra names:\n" + "\n".join(extras or ["none"]))
    print("\nestimates where named:\n" + "\n".join(named))
    print(json.dumps({"schema": "brakefit.gap_c_suite/1", "version": "0.1.0", "commit": commit,
                      "seeds": seeds, "sets": len(truth),
                      "counts": {k: {"ok": v[0], "of": v[1]} for k, v in rows.items()},
                      "per_effect": {k: {"named": v[0], "of": v[1]} for k, v in per_effect.items()},
                      "magnitude_error_median": {e: statistics.median(v) for e, v in errors.items()},
                      "load_transfer_error_median_by_tyre":
                          {t: statistics.median(v) for t, v in load_by_tyre.items()},
                      "load_transfer_inside_published_band_by_tyre":
                          {t: {"inside": c[0], "of": c[1]} for t, c in band_by_tyre.items()},
                      "misses": misses, "extra_names": extras}))
    if a.results:
        write_results(a.results, text, a.results_key)
        log(f"wrote the table into {a.results}")


if __name__ == "__main__":
    main()
