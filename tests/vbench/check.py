"""Judges what the virtual bench's guest left in OUT: check.py ROOT BUILD OUT GPIO_SCALE.

Prints the figures (frames replayed vs received, the published parameters against `brakefit
replay`, edges driven vs counted per reader delay) and exits 1 on any failed expectation. Writes
OUT/summary.json (brakefit.vbench/1).
"""
import json
import math
import os
import re
import struct
import subprocess
import sys

from readings import f32, link_tx, net_counts, pressure_lag_ms, read_frames, regs, u32

ROOT, BUILD, OUT, SCALE = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4])
BRAKEFIT = os.path.join(BUILD, "cli", "brakefit")
REC = os.path.join(ROOT, "data", "recorded")
METHODS = ["som", "mlp", "lm", "hybrid"]
FIELDS = ["B", "C", "D", "E"]
BENCH_IDS = {0x100, 0x101, 0x102, 0x103, 0x110, 0x120, 0x130}
FOREIGN_IDS = {0x200, 0x7FF, 0x1ABCDEF0}
# The GPIO path against `brakefit replay` of the played log, within what the edge timing allows.
# The edges are the log's, stretched x6 in time on a 6x coarser encoder, but written by a player
# that shares one TCG vCPU with the daemon: 32-170 of 36 712 edges land > 0.5 ms late (up to
# 16 ms, mostly while the daemon closes the event), so a few samples' slips move. What a station
# sees is asserted: the fitted curves over the measured slip range (RMS within 8 %, worst point
# within 15 % of the reference peak force; measured over 6 runs 1.7-5.8 % and 3.4-9.9 %), the peak
# force within 2 % (measured 0.02 %), the peak slip within 0.05 (measured 0.007-0.029: one late
# edge moves one sample), the point count within 1 % (measured 2-8 of 2 041), and the SOM's D
# within 5 % (measured 0.2-3 %). The MLP's D is reported, not judged: the network reads D off the
# curve's shape, so it moves more than the curve does (one CI run: the MLP's curve 6.2 % RMS from
# the reference, within tolerance, its D 7.4 %); the SOM's D is a least-squares scale over the
# samples, where a driver's fault would show. The pressure's lag behind the edges (the RTU reading
# against the log, placed in log time by the encoder count) is printed and kept in summary.json.
# The daemon's edge reader runs SCHED_FIFO 20 here (gpio.reader_rt_priority): as SCHED_OTHER it
# was once held off a whole 6 ms frame, and that frame's wheel speed (no new edge) made one
# sample's slip 0.72. B, C, E are reported: LM's B, C and E trade along a ridge on this event (the
# log's own fit has E at its bound 1.0; the GPIO run's once has C at its bound 0.3 with a curve
# 5 % RMS from the reference), so they are not a measure of the driver. A player held off longer
# than one scaled frame inside the event (the daemon then sees the wheel without edges and closes
# the event early: once at 1 405 of 2 041 points) did not drive the log: those comparisons are
# then printed "not judged" and summary.json says gpio_player_stalled_in_event; counts and the
# recording's replay are judged in every run.
CURVE_RMS_TOL, CURVE_MAX_TOL, PEAK_FORCE_TOL, PEAK_SLIP_TOL, POINTS_TOL, D_TOL = \
    0.08, 0.15, 0.02, 0.05, 0.01, 0.05
# The MLP reads its curve off the event's shape, so the edge timing moves it further than the
# least-squares curves (the five-network MLP: 5.6 and 9.4 % RMS, 7.2 and 13.2 % at worst, over
# two runs whose SOM, LM and hybrid curves moved 1.7-3.7 %): its own bounds. A driver's fault
# shows in the counts, the recording's replay and the least-squares curves.
MLP_CURVE_RMS_TOL, MLP_CURVE_MAX_TOL = 0.15, 0.25

failures = []
summary = {"schema": "brakefit.vbench/1", "version": 1}


def expect(ok, what):
    print(("  ok    " if ok else "  FAIL  ") + what)
    if not ok:
        failures.append(what)


def published(r):
    """The event block's parameters per method."""
    out = {}
    for k, m in enumerate(METHODS):
        base = 120 + 12 * k
        out[m] = {f: f32(r, base + 2 * i) for i, f in enumerate(FIELDS)}
    return out


def replay(log, bench):
    p = subprocess.run([BRAKEFIT, "replay", "--json", "--bench", bench, log], capture_output=True,
                       text=True, check=False)
    docs = [json.loads(x) for x in p.stdout.splitlines() if x.startswith("{")]
    return docs


def params(doc):
    return {r["method"]: {f: r[f] for f in FIELDS} for r in doc["results"]}


def f32_equal(a, b):
    """Equal as published (f32), allowing the last bits of the LM's sums: the daemon and the CLI
    run the same code, but Eigen's vectorised sums start at an address-dependent element, and an
    ill-conditioned fit carries that 1e-16 on (measured: hybrid C 2.0852918625 vs 2.0852917427)."""
    fa = struct.unpack(">f", struct.pack(">f", a))[0]
    fb = struct.unpack(">f", struct.pack(">f", b))[0]
    return fa == fb or abs(fa - fb) <= 1e-5 * max(abs(fa), abs(fb))


def mf(p, s):
    x = p["B"] * s
    return p["D"] * math.sin(p["C"] * math.atan(x - p["E"] * (x - math.atan(x))))


def table(rows):
    for r in rows:
        print("    " + "  ".join(f"{c:>12}" for c in r))


# ------------------------------------------------------------------ SocketCAN
print("SocketCAN on vcan0 (canplayer -> brakefitd, candump -L alongside)")
can_out = os.path.join(OUT, "can")
inp = read_frames(os.path.join(can_out, "input.log"))
dump = read_frames(os.path.join(can_out, "candump.log"))
rec = read_frames(os.path.join(can_out, "recorded.log"))
n_bench = sum(1 for f in inp if f[1] in BENCH_IDS)
n_foreign = sum(1 for f in inp if f[1] in FOREIGN_IDS)
d_bench = sum(1 for f in dump if f[1] in BENCH_IDS)
d_foreign = sum(1 for f in dump if f[1] in FOREIGN_IDS)
r0, r1 = regs(os.path.join(can_out, "regs_before.txt")), regs(os.path.join(can_out, "regs_event.txt"))
daemon_frames = u32(r1, 4) - u32(r0, 4)
print(f"    replayed {n_bench} bench + {n_foreign} foreign frames; candump saw {d_bench} + "
      f"{d_foreign}; the daemon received {daemon_frames} (unknown ids {u32(r1, 18)})")
expect(d_bench == n_bench and d_foreign == n_foreign, "candump saw every replayed frame")
expect(daemon_frames == n_bench, "the daemon received exactly the bench frames (kernel filter "
       f"dropped the {n_foreign} foreign ones)")
expect(u32(r1, 18) == 0, "no unknown id reached the daemon")
summary["can"] = {"replayed_bench": n_bench, "replayed_foreign": n_foreign,
                  "candump_bench": d_bench, "candump_foreign": d_foreign,
                  "daemon_frames": daemon_frames}
# The daemon's recording against candump -L, up to candump's last frame.
if dump:
    t_last = dump[-1][0]
    rec_cut = [f for f in rec if f[0] <= t_last]
    dump_bench = [f for f in dump if f[1] in BENCH_IDS]
    same_frames = [(i, d) for _, i, d in rec_cut] == [(i, d) for _, i, d in dump_bench]
    same_stamps = [t for t, _, _ in rec_cut] == [t for t, _, _ in dump_bench]
    expect(same_frames, f"the daemon's recording and candump -L have the same {len(rec_cut)} "
           "frames (ids and data, in order)")
    print(f"    time stamps identical: {same_stamps}")
    summary["can"]["recording_equals_candump"] = same_frames
    summary["can"]["stamps_equal"] = same_stamps
can_log = "roller_1p0bar_fast"
ref = replay(os.path.join(REC, can_log + ".log"), os.path.join(REC, can_log + ".bench.toml"))
pub = published(r1)
rows = [["method", "param", "published", "replay(log)", "rel diff"]]
worst = 0.0
worst_curve = 0.0 if ref else math.inf
if ref:
    smax = ref[0]["max_slip_ratio"]
    for m, ps in params(ref[0]).items():
        for f in FIELDS:
            a, b = pub[m][f], ps[f]
            rel = abs(a - b) / max(abs(b), 1e-9)
            if f != "E":
                worst = max(worst, rel)
            rows.append([m, f, f"{a:.5g}", f"{b:.5g}", f"{rel:.2e}"])
        # E is a shape number around zero, which a small change of the curve's shape moves by
        # more than the others: it is judged through the curve, its RMS difference over the
        # event's slip against the reference peak.
        d = [mf(pub[m], smax * i / 200) - mf(ps, smax * i / 200) for i in range(1, 201)]
        worst_curve = max(worst_curve, math.sqrt(sum(v * v for v in d) / len(d)) / abs(ps["D"]))
table(rows)
# Frames are stamped on receipt (SO_TIMESTAMP), not with the log's times: samples are grouped by
# those stamps, so an ill-conditioned fit (lm's E with C at its bound) moves by a few 1e-3, and
# the MLP's E of 0.85 by up to 0.02 (its curve by 0.07 % of the peak).
expect(bool(ref) and worst < 1e-2 and worst_curve < 1e-2,
       f"published parameters equal brakefit replay of the shipped log within 1 % (B, C, D: "
       f"worst relative difference {worst:.2e}; each curve, E included: RMS {worst_curve:.2%} of "
       f"the peak)")
summary["can"]["params_worst_rel_diff_vs_replay"] = worst
summary["can"]["curve_worst_rms_vs_replay"] = worst_curve
rec_docs = replay(os.path.join(can_out, "recorded.log"), os.path.join(REC, can_log + ".bench.toml"))
exact = bool(rec_docs) and all(f32_equal(pub[m][f], v) for m, ps in params(rec_docs[0]).items()
                               for f, v in ps.items())
expect(exact, "replaying the daemon's recording gives the published parameters (f32, 1e-5)")
# The burst.
tx0 = link_tx(os.path.join(can_out, "link_burst_before.txt"))
tx1 = link_tx(os.path.join(can_out, "link_burst_after.txt"))
b0, b1 = regs(os.path.join(can_out, "regs_burst_before.txt")), regs(os.path.join(can_out, "regs_burst_after.txt"))
sent = (tx1 - tx0) if tx0 is not None and tx1 is not None else None
got = u32(b1, 4) - u32(b0, 4)
dropped = u32(b1, 52) - u32(b0, 52)
print(f"    burst: {sent} frames sent back to back, daemon received {got}, kernel reported "
      f"{dropped} dropped (SO_RXQ_OVFL, register can_rx_dropped)")
expect(sent is not None and sent > 0 and got + dropped == sent,
       "the burst is received whole or its loss is reported (received + dropped = sent)")
summary["can"]["burst"] = {"sent": sent, "received": got, "dropped_reported": dropped}

# ------------------------------------------------------------------ GPIO
print(f"GPIO on gpio-sim (bench_player edges x{SCALE:g} time, RTU pressure on a pty -> brakefitd)")
g_out = os.path.join(OUT, "gpio")
player = open(os.path.join(g_out, "player.txt"), encoding="utf-8").read() \
    if os.path.exists(os.path.join(g_out, "player.txt")) else ""
print("    " + player.strip().replace("\n", "\n    "))
pl = dict(re.findall(r"(\w+)=([^\s]+)", player.split("PLAY", 1)[1])) if "PLAY" in player else {}
ginp = read_frames(os.path.join(g_out, "input.log"))
grec = read_frames(os.path.join(g_out, "recorded.log"))
want, have = net_counts(ginp), net_counts(grec)
print(f"    net x4 counts: log {want}, the daemon's recording {have}")
expect(bool(have) and have.get(0x100) == want.get(0x100) and have.get(0x101) == want.get(0x101),
       "every driven edge was counted (net counts of the recording equal the log's)")
g = regs(os.path.join(g_out, "regs_event.txt"))
lost, illegal, flags = u32(g, 50), u32(g, 10), g.get(104, 0)
print(f"    lost_edges {lost}, illegal_transitions {illegal}, event.flags 0x{flags:04x}")
expect(((flags >> 5) & 1) == (1 if lost + illegal > 0 else 0),
       "the event is flagged edges_lost exactly when edges were lost")
gpub = published(g)
gbench = os.path.join(g_out, "scaled.bench.toml")
grec_docs = replay(os.path.join(g_out, "recorded.log"), gbench)
gexact = bool(grec_docs) and all(f32_equal(gpub[m][f], v)
                                 for m, ps in params(grec_docs[0]).items() for f, v in ps.items())
expect(gexact, "replaying the daemon's recording gives the published parameters (f32, 1e-5)")
gref = replay(os.path.join(g_out, "input.log"), os.path.join(g_out, "ref.bench.toml"))
rows = [["method", "param", "published", "replay(log)", "rel diff"]]
gworst = {}
if gref:
    for m, ps in params(gref[0]).items():
        for f in FIELDS:
            a, b = gpub[m][f], ps[f]
            rel = abs(a - b) / max(abs(b), 1e-9)
            rows.append([m, f, f"{a:.5g}", f"{b:.5g}", f"{rel:.2e}"])
            gworst[f] = max(gworst.get(f, 0.0), rel)
table(rows)


curves = {}
if gref:
    smax = gref[0]["max_slip_ratio"]
    grid = [smax * i / 200 for i in range(1, 201)]
    for m, ps in params(gref[0]).items():
        d = [mf(gpub[m], x) - mf(ps, x) for x in grid]
        curves[m] = (math.sqrt(sum(v * v for v in d) / len(d)) / ps["D"],
                     max(abs(v) for v in d) / ps["D"])
    print("    fitted curves over the measured slip range, difference / reference peak force: "
          + ", ".join(f"{m} RMS {r:.1%} max {x:.1%}" for m, (r, x) in curves.items()))
    # The player shares the vCPU: held off longer than one (scaled) 1 ms frame inside the event,
    # it did not drive the log there, and the daemon rightly saw a wheel without edges (the event
    # then ends early). That is the harness, not the driver: the comparison with the log's replay
    # is printed, not judged, and the summary says so; counts and the recording's replay above
    # are judged in every run.
    late_ms, late_at_s = float(pl.get("worst_late_ms", 0)), float(pl.get("worst_at_log_s", -1))
    t0_us = ginp[0][0] if ginp else 0
    ev_from_s = (gref[0]["t_start_ns"] / 1e3 - t0_us) / 1e6
    ev_to_s = (gref[0]["t_end_ns"] / 1e3 - t0_us) / 1e6
    stalled = late_ms > SCALE and ev_from_s <= late_at_s <= ev_to_s

    def judge(ok, what):
        if stalled:
            print(("  ok    " if ok else "  (not judged)  ") + what)
        else:
            expect(ok, what)

    summary["gpio_player_stalled_in_event"] = stalled
    if stalled:
        print(f"    NOT JUDGED: the player was held off {late_ms:.1f} ms (more than one {SCALE:g} ms "
              f"frame) at log {late_at_s:.3f} s, inside the event ({ev_from_s:.3f}-{ev_to_s:.3f} s): "
              "the daemon was not driven the log there; the comparisons below are reported only")
    judge(all(r <= CURVE_RMS_TOL and x <= CURVE_MAX_TOL for m, (r, x) in curves.items()
              if m != "mlp") and len(curves) > 1,
          f"every least-squares and SOM curve within {CURVE_RMS_TOL:.0%} RMS and "
          f"{CURVE_MAX_TOL:.0%} at worst")
    if "mlp" in curves:
        r, x = curves["mlp"]
        judge(r <= MLP_CURVE_RMS_TOL and x <= MLP_CURVE_MAX_TOL,
              f"the MLP's curve within {MLP_CURVE_RMS_TOL:.0%} RMS and {MLP_CURVE_MAX_TOL:.0%} at "
              "worst")
    pf, ps_, pts = f32(g, 109), f32(g, 111), g.get(108, 0)
    print(f"    peak force {pf:.1f} N (replay {gref[0]['max_force_n']:.1f}), peak slip {ps_:.4f} "
          f"(replay {smax:.4f}), points {pts} (replay {gref[0]['points']})")
    judge(abs(pf - gref[0]["max_force_n"]) <= PEAK_FORCE_TOL * gref[0]["max_force_n"],
          f"peak force within {PEAK_FORCE_TOL:.0%}")
    judge(abs(ps_ - smax) <= PEAK_SLIP_TOL, f"peak slip within {PEAK_SLIP_TOL}")
    judge(abs(pts - gref[0]["points"]) <= POINTS_TOL * gref[0]["points"],
          f"point count within {POINTS_TOL:.0%}")
    dref = params(gref[0])
    print(f"    D: som {gpub['som']['D']:.1f} N (replay {dref['som']['D']:.1f}), mlp "
          f"{gpub['mlp']['D']:.1f} N (replay {dref['mlp']['D']:.1f}, reported only)")
    judge(abs(gpub["som"]["D"] - dref["som"]["D"]) <= D_TOL * dref["som"]["D"],
          f"D of the SOM within {D_TOL:.0%}")
    lag = pressure_lag_ms(ginp, grec, ev_from_s, ev_to_s)
    if lag:
        print(f"    pressure behind the edges inside the event (log ms, one RTU poll is "
              f"{10 / SCALE:.1f}): median {lag['median']:.1f}, range {lag['min']:.1f} to "
              f"{lag['max']:.1f} over {lag['readings']} readings")
    summary["gpio_pressure_lag_ms"] = lag
else:
    expect(False, "brakefit replay of the played log found its event")
summary["gpio"] = {"scale": SCALE, "player": pl, "net_counts_log": {hex(k): v for k, v in want.items()},
                   "net_counts_recorded": {hex(k): v for k, v in have.items()},
                   "lost_edges": lost, "illegal_transitions": illegal,
                   "recording_replays_exactly": gexact, "worst_rel_diff_vs_replay": gworst,
                   "curve_rms_max_vs_replay": curves}

# ------------------------------------------------------------------ edge loss
print("Edge loss of the GPIO reader as it is delayed (one encoder, lines 0/1)")
runs = []
ep = os.path.join(OUT, "edges", "edges.txt")
if os.path.exists(ep):
    for ln in open(ep, encoding="utf-8"):
        if ln.startswith("EDGES"):
            runs.append({k: (v if k == "uapi" else float(v))
                         for k, v in re.findall(r"(\w+)=([^\s]+)", ln)})
rows = [["uapi", "fifo", "delay_ms", "edges/s", "driven", "counted", "illegal", "lost_rep"]]
for r in sorted(runs, key=lambda r: (r["period_us"], r["uapi"], r["buffer"], r["delay_ms"])):
    rows.append([r["uapi"], int(r["buffer"]), int(r["delay_ms"]), int(r["rate_edges_per_s"]),
                 int(r["driven"]), int(r["counted"]), int(r["illegal"]), int(r["lost_reported"])])
table(rows)
v2 = [r for r in runs if r["uapi"] == "v2" and r["buffer"] == 1024]
periods = sorted({int(r["period_us"]) for r in v2})
expect(len(v2) == 4 * len(periods) and all(r["counted"] == r["driven"] and r["lost_reported"] == 0 and
                            r["illegal"] == 0 for r in v2),
       "v2 uAPI, 1024-event FIFO: every edge counted at reader delays 0, 1, 3, 10 ms, "
       f"{', '.join(str(round(1e6 / p)) for p in periods)} edges/s")
small = [r for r in runs if r["uapi"] == "v2" and r["buffer"] == 16]
expect(len(small) == 1 and small[0]["lost_reported"] > 0,
       "v2 uAPI with a 16-event FIFO and a 10 ms reader: the loss is reported")
expect(all(r["counted"] == r["driven"] or r["lost_reported"] > 0 or r["illegal"] > 0
           for r in runs if r["uapi"] == "v2"), "v2: no loss passes unnoticed")
silent = [r for r in runs if r["uapi"] == "v1" and r["counted"] != r["driven"] and r["illegal"] == 0]
print(f"    v1 (libgpiod 1.6): {len(silent)} of {sum(1 for r in runs if r['uapi'] == 'v1')} runs "
      "miscounted with no illegal transition to show it (why the daemon uses v2)")
summary["edges"] = runs

with open(os.path.join(OUT, "summary.json"), "w", encoding="utf-8") as f:
    json.dump(summary, f, indent=1)
if failures:
    print(f"vbench: {len(failures)} expectation(s) failed")
    sys.exit(1)
print("vbench: all expectations hold")
