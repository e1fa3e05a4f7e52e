"""Readers of what the virtual bench's guest left: candump -L files, the daemon's Modbus register
dumps, encoder counts over frames, the pressure's lag behind the edges, a link's TX counter."""
import bisect
import os
import re
import struct


def read_frames(path):
    """(t_us, id, data hex) of a candump -L style file."""
    out = []
    if not os.path.exists(path):
        return out
    with open(path, encoding="utf-8", errors="replace") as f:
        for ln in f:
            m = re.match(r"\((\d+)\.(\d{6})\) \S+ ([0-9A-Fa-f]+)#(\S*)", ln)
            if m:
                out.append((int(m.group(1)) * 1_000_000 + int(m.group(2)), int(m.group(3), 16),
                            m.group(4).upper()))
    return out


def regs(path):
    r = {}
    if os.path.exists(path):
        with open(path, encoding="utf-8") as f:
            for ln in f:
                m = re.match(r"\[(\d+)\]:\s*(-?\d+)", ln)
                if m:
                    r[int(m.group(1))] = int(m.group(2)) & 0xFFFF
    return r


def u32(r, a):
    return (r.get(a, 0) << 16) | r.get(a + 1, 0)


def f32(r, a):
    return struct.unpack(">f", struct.pack(">I", u32(r, a)))[0]


def count_series(frames, ident):
    """(t_us, cumulative net x4 count) of one encoder id over a frame list (modulo arithmetic of
    the layout), the count 0 at its first frame."""
    t, c, last, acc = [], [], None, 0
    for tt, i, data in frames:
        if i != ident or len(data) < 6:
            continue
        b = bytes.fromhex(data)
        v = b[0] | b[1] << 8 | b[2] << 16
        if last is not None:
            d = (v - last) & 0xFFFFFF
            acc += d - 0x1000000 if d & 0x800000 else d
        last = v
        t.append(tt)
        c.append(acc)
    return t, c


def net_counts(frames):
    """Net x4 count per encoder id over a frame list."""
    net = {}
    for i in (0x100, 0x101, 0x102):
        _, c = count_series(frames, i)
        if len(c) > 1:
            net[i] = c[-1]
    return net


def pressure_lag_ms(log, rec, from_s, to_s):
    """How far the daemon's pressure readings lag the edges, in log milliseconds: each recorded
    pressure is placed in log time by the roller encoder's count at that moment, then matched to
    the nearest time the log's pressure had that value (ramp readings only)."""
    def pressures(frames):
        return [(t, int(d[2:4] + d[0:2], 16) * 0.01) for t, i, d in frames if i == 0x110 and len(d) >= 4]

    lt, lc = count_series(log, 0x100)
    rt, rc = count_series(rec, 0x100)
    lp = pressures(log)
    if not lt or not rt or not lp:
        return None
    lpt = [t for t, _ in lp]
    lags = []
    for t, p in pressures(rec):
        k = max(bisect.bisect_right(rt, t) - 1, 0)
        tl = lt[min(bisect.bisect_left(lc, rc[k]), len(lt) - 1)]
        if not from_s <= (tl - lt[0]) / 1e6 <= to_s:
            continue
        j0 = bisect.bisect_left(lpt, tl)
        near = [(abs(lp[j][1] - p), abs(lpt[j] - tl), j)
                for j in range(max(0, j0 - 150), min(len(lp), j0 + 150))]
        err, _, j = min(near)
        if err < 0.02:
            lags.append((tl - lpt[j]) / 1e3)
    if not lags:
        return None
    lags.sort()
    return {"readings": len(lags), "median": lags[len(lags) // 2], "min": lags[0], "max": lags[-1]}


def link_tx(path):
    if not os.path.exists(path):
        return None
    with open(path, encoding="utf-8") as f:
        text = f.read()
    m = re.search(r"TX:\s+bytes\s+packets.*?\n\s*(\d+)\s+(\d+)", text)
    return int(m.group(2)) if m else None
