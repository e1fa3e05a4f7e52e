"""Candump log helpers shared by the daemon tests and bench/daemon_bench.py: read, write, and
join recorded tests into one longer session."""
import re


def read_text(path):
    with open(path) as f:
        return f.read()


def read_log(path):
    frames = []
    for line in read_text(path).splitlines():
        m = re.match(r"\((\d+)\.(\d+)\) (\S+) (\S+)", line)
        frames.append([int(m.group(1)) * 1_000_000 + int(m.group(2)), m.group(3), m.group(4)])
    return frames


def write_log(path, frames):
    with open(path, "w") as f:
        for t, iface, fr in frames:
            f.write(f"({t // 1_000_000:010d}.{t % 1_000_000:06d}) {iface} {fr}\n")


ENCODER_IDS = ("100", "101", "102")


def concat(parts, gap_us=500_000):
    """Frame lists one after the other, each shifted to start gap_us after the previous end; the
    encoder frames' cumulative counts and sender edge times continue across the joins, as on a
    bench that kept running."""
    out, last_count = [], {}
    for p in parts:
        shift = 0 if not out else out[-1][0] + gap_us - p[0][0]
        first_count, offset = {}, {}
        for t, iface, fr in p:
            cid, data = fr.split("#")
            if cid in ENCODER_IDS:
                b = bytearray.fromhex(data)
                count = int.from_bytes(b[0:3], "little")
                if cid not in offset:
                    offset[cid] = (last_count.get(cid, count) - count) % (1 << 24)
                count = (count + offset[cid]) % (1 << 24)
                edge = (int.from_bytes(b[3:7], "little") + shift) % (1 << 32)
                b[0:3] = count.to_bytes(3, "little")
                b[3:7] = edge.to_bytes(4, "little")
                last_count[cid] = count
                fr = f"{cid}#{b.hex().upper()}"
            out.append([t + shift, iface, fr])
    return out
