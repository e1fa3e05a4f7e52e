"""Writes the virtual bench's inputs and daemon configs: prepare.py ROOT BRAKEFIT OUT GPIO_SCALE.

can/input.log      a shipped roller recording with frames of foreign ids interleaved (standard
                   0x200 and 0x7FF, extended 0x1ABCDEF0, every 10 ms) for canplayer
can/brakefitd.toml.in, gpio/brakefitd.toml.in
                   daemon configs (@STORE@, @REC@, @CHIP@, @TTY@ filled in by guest.sh)
gpio/input.log     the recording the GPIO player turns into edges and RTU answers, up to 0.2 s
                   after its event ends (`brakefit replay`): after switch-off the simulated
                   wheel is let go and spins up past 20 000 edges/s, which no TCG guest drives
gpio/scaled.bench.toml
                   its calibration with every encoder's pulses per revolution divided by
                   GPIO_SCALE: the player stretches time by GPIO_SCALE (one TCG vCPU drives about
                   9 000 edges/s in lock-step; the recording has 11 800), so the same counts over
                   GPIO_SCALE times the time on an encoder GPIO_SCALE times coarser are the same
                   speeds in m/s; slip, pressure and force are unchanged.
"""
import json
import os
import re
import subprocess
import sys

ROOT, BRAKEFIT, OUT, SCALE = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4])
REC = os.path.join(ROOT, "data", "recorded")
CAN_LOG = "roller_1p0bar_fast"
GPIO_LOG = "roller_2p2bar_medium"
FOREIGN = ["200#0102030405060708", "7FF#DEADBEEF", "1ABCDEF0#00FF00FF"]


def read(p):
    with open(p, encoding="utf-8") as f:
        return f.read()


def write(p, text):
    os.makedirs(os.path.dirname(p), exist_ok=True)
    with open(p, "w", encoding="utf-8") as f:
        f.write(text)


def common(store_kind, bench_toml):
    return f"""[daemon]
log_level = "info"
model = "{ROOT}/data/models/default.json"
sensor_timeout_s = 1.0

{store_kind}

{bench_toml}
[modbus_tcp]
address = "127.0.0.1"
port = 1502

[store]
path = "@STORE@"
min_free_mb = 1

[record]
enabled = true
dir = "@REC@"
"""


# SocketCAN: the log with foreign frames every 10 ms.
lines = read(os.path.join(REC, CAN_LOG + ".log")).splitlines()
out, next_us, k = [], None, 0
for ln in lines:
    m = re.match(r"\((\d+)\.(\d+)\) (\S+) ", ln)
    t_us = int(m.group(1)) * 1_000_000 + int(m.group(2))
    if next_us is None:
        next_us = t_us
    while t_us >= next_us:
        out.append(f"({next_us // 1_000_000}.{next_us % 1_000_000:06d}) can0 {FOREIGN[k % 3]}")
        k += 1
        next_us += 10_000
    out.append(ln)
write(os.path.join(OUT, "can", "input.log"), "\n".join(out) + "\n")
can_bench = read(os.path.join(REC, CAN_LOG + ".bench.toml"))
write(os.path.join(OUT, "can", "brakefitd.toml.in"),
      common('[source]\nkind = "socketcan"\ninterface = "vcan0"', can_bench))

# GPIO: the recording up to its event's end, its encoders made coarser as time is stretched.
gpio_src = os.path.join(REC, GPIO_LOG + ".log")
ev = json.loads(subprocess.run([BRAKEFIT, "replay", "--json", "--method", "lm", gpio_src],
                               check=True, capture_output=True, text=True).stdout.splitlines()[0])
end_us = ev["t_end_ns"] // 1000
kept = []
for ln in read(gpio_src).splitlines():
    t_us = int(ln[1:11]) * 1_000_000 + int(ln[12:18])
    if t_us > end_us + 200_000:
        break
    if " 120#" in ln or " 130#" in ln:
        continue  # the GPIO bench has no tester force or state: encoders and pressure only
    if t_us > end_us + 20_000 and " 110#" in ln:
        ln = ln[:ln.index("#") + 1] + "0000" + ln[ln.index("#") + 5:]  # the brake released
    kept.append(ln)
write(os.path.join(OUT, "gpio", "input.log"), "\n".join(kept) + "\n")
# Switch-off on one sample's slip is where edge-time jitter shows first (a late edge makes a
# sample's slip jump): the event ends at the release 20 ms after the log's switch-off instead,
# in the daemon and in the reference replay alike (ref.bench.toml).
bench = re.sub(r"^switch_off_slip_ratio = .*$", "switch_off_slip_ratio = 0.9",
               read(os.path.join(REC, GPIO_LOG + ".bench.toml")), flags=re.M)
write(os.path.join(OUT, "gpio", "ref.bench.toml"), bench)


def scale_ppr(m):
    return f"{m.group(1)} = {float(m.group(2)) / SCALE!r}"


scaled = re.sub(r"^(\w+_ppr) = ([0-9.eE+-]+)$", scale_ppr, bench, flags=re.M)
write(os.path.join(OUT, "gpio", "scaled.bench.toml"), scaled)
gpio = """[source]
kind = "gpio"

[gpio]
chip = "@CHIP@"
ref_a = 0
ref_b = 1
wheel_a = 2
wheel_b = 3
uapi = "v2"
frame_period_ms = @FRAME_MS@
reader_rt_priority = 20

[modbus_rtu]
device = "@TTY@"
baud = 115200
parity = "N"
slave_id = 1
register = 0
register_type = "input"
format = "u16"
span_bar_per_count = 0.01
poll_period_ms = 10
timeout_ms = 200
"""
# Encoder frames every GPIO_SCALE ms: one per millisecond of the log, as the recording has them.
gpio = gpio.replace("@FRAME_MS@", os.environ.get("VBENCH_FRAME_MS", str(max(1, round(SCALE)))))
write(os.path.join(OUT, "gpio", "brakefitd.toml.in"), common(gpio, scaled))
print(f"vbench: inputs in {OUT} (can: {CAN_LOG} + {k} foreign frames; gpio: {GPIO_LOG} x{SCALE:g})")
