#!/bin/bash
# Runs inside the QEMU guest (chrooted into the host root over 9p) as its only job. Reads
# $VB_OUT/env.sh (written by run.sh), loads the kernel modules, runs the scenarios and leaves raw
# figures in $VB_OUT (the host's check.py judges them). Every step prints "VB: ..." to the console.
set -uo pipefail
ENVF=$(sed -n 's/.*vb_env=\([^ ]*\).*/\1/p' /proc/cmdline)
# shellcheck disable=SC1090
source "$ENVF"
export PATH=/usr/sbin:/usr/bin:/sbin:/bin
say() { echo "VB: $(cut -d' ' -f1 /proc/uptime)s $*"; }
fail=0
M=$KROOT/lib/modules/$KVER/kernel
for m in net/can/can.ko net/can/can-raw.ko drivers/net/can/dev/can-dev.ko drivers/net/can/vcan.ko \
         fs/configfs/configfs.ko; do
  busybox insmod "$M/$m" || { say "insmod $m failed"; fail=1; }
done
busybox insmod "$GPIOSIM_KO" || { say "insmod gpio-sim.ko failed"; fail=1; }
mount -t configfs none /sys/kernel/config 2>/dev/null || true
ip link set lo up || { say "lo failed"; fail=1; }
ip link add dev vcan0 type vcan && ip link set up vcan0 || { say "vcan0 failed"; fail=1; }
say "modules loaded (rc $fail), kernel $(uname -r)"
RUN=/run/vb; mkdir -p "$RUN"

mbread() {  # mbread FILE: input registers 0..59 and 100..168 of the daemon on 127.0.0.1:$PORT
  { mbpoll -m tcp -p "$PORT" -a 1 -t 3 -0 -1 -q -r 0 -c 60 127.0.0.1
    mbpoll -m tcp -p "$PORT" -a 1 -t 3 -0 -1 -q -r 100 -c 69 127.0.0.1; } > "$1" 2>&1
}
wait_port() {  # until the daemon ($1) answers Modbus (or 60 s); 1 when it exited
  for _ in $(seq 1 120); do
    kill -0 "$1" 2>/dev/null || return 1
    mbpoll -m tcp -p "$PORT" -a 1 -t 3 -0 -1 -q -r 0 -c 1 127.0.0.1 >/dev/null 2>&1 && return 0
    sleep 0.5
  done
  return 1
}
wait_event() {  # until event.seq (input register 168) is not 0 (or $1 s)
  for _ in $(seq 1 $(( $1 * 2 ))); do
    kill -0 "$2" 2>/dev/null || return 1
    v=$(mbpoll -m tcp -p "$PORT" -a 1 -t 3 -0 -1 -q -r 168 -c 1 127.0.0.1 2>/dev/null | sed -n 's/^\[168\]:[[:space:]]*//p')
    [ -n "$v" ] && [ "$v" != "0" ] && return 0
    sleep 0.5
  done
  return 1
}
stop_daemon() {
  kill -TERM "$1" 2>/dev/null
  for _ in $(seq 1 100); do kill -0 "$1" 2>/dev/null || return 0; sleep 0.1; done
  kill -KILL "$1" 2>/dev/null
}
PORT=1502

# ---------------------------------------------------------------- SocketCAN on vcan0
if [ -z "${VB_ONLY:-}" ] || [ "$VB_ONLY" = can ]; then
  say "can: start"
  O=$VB_OUT/can; mkdir -p "$O"; D=$RUN/can; mkdir -p "$D/rec"
  sed -e "s#@STORE@#$D/events.db#" -e "s#@REC@#$D/rec#" "$O/brakefitd.toml.in" > "$D/brakefitd.toml"
  "$BRAKEFITD" -c "$D/brakefitd.toml" > "$O/daemon.log" 2>&1 &
  dpid=$!
  wait_port "$dpid" || { say "can: daemon does not answer: $(tail -3 "$O/daemon.log")"; fail=1; }
  candump -L vcan0 > "$D/candump.log" &
  cpid=$!
  sleep 0.3
  ip -s -s link show vcan0 > "$O/link_before.txt"
  mbread "$O/regs_before.txt"
  t0=$(date +%s.%N)
  canplayer -I "$O/input.log" vcan0=can0
  say "can: canplayer done in $(echo "$(date +%s.%N) - $t0" | bc) s"
  wait_event 60 "$dpid" || { say "can: no event published"; fail=1; }
  mbread "$O/regs_event.txt"
  kill -TERM "$cpid"; wait "$cpid" 2>/dev/null
  # A burst faster than the daemon reads: bench-id frames (test state idle, no samples) back to
  # back; what the kernel sent is on the interface's counters.
  ip -s -s link show vcan0 > "$O/link_burst_before.txt"
  mbread "$O/regs_burst_before.txt"
  cangen vcan0 -I 130 -L 8 -D 0000000000000000 -g 0 -n "$CAN_BURST" -i 2> "$O/cangen.err"
  ip -s -s link show vcan0 > "$O/link_burst_after.txt"
  sleep 2
  mbread "$O/regs_burst_after.txt"
  stop_daemon "$dpid"; wait "$dpid" 2>/dev/null
  cp "$D/candump.log" "$O/candump.log"
  cat "$D"/rec/*.log > "$O/recorded.log" 2>/dev/null
  say "can: done"
fi

# ---------------------------------------------------------------- GPIO (gpio-sim) + RTU pressure
G=/sys/kernel/config/gpio-sim/vb
setup_chip() {
  mkdir -p $G/bank0 && echo 4 > $G/bank0/num_lines && echo 1 > $G/live || return 1
  CHIP=$(cat $G/bank0/chip_name); DEV=$(cat $G/dev_name)
  SIM=/sys/devices/platform/$DEV/$CHIP
  [ -e "/dev/$CHIP" ] && [ -e "$SIM/sim_gpio0/pull" ]
}
if [ -z "${VB_ONLY:-}" ] || [ "$VB_ONLY" = gpio ] || [ "$VB_ONLY" = edges ]; then
  if ! setup_chip; then
    say "gpio: gpio-sim chip could not be created"; fail=1
  elif [ "${VB_ONLY:-}" != edges ]; then
    say "gpio: chip $CHIP ($SIM)"
    O=$VB_OUT/gpio; mkdir -p "$O"; D=$RUN/gpio; mkdir -p "$D/rec"
    rm -f "$D/go"
    # SCHED_FIFO 10: above the daemon (a late edge write is a wrong edge time), below the
    # IRQ threads (50) that turn each write into an edge event.
    chrt -f 10 "$PLAYER" play "$O/input.log" "$SIM" "$D/ttyRTU" "$GPIO_SCALE" "$D/go" > "$O/player.txt" 2>&1 &
    ppid=$!
    for _ in $(seq 1 100); do [ -e "$D/ttyRTU" ] && break; sleep 0.1; done
    sed -e "s#@STORE@#$D/events.db#" -e "s#@REC@#$D/rec#" -e "s#@CHIP@#/dev/$CHIP#" \
        -e "s#@TTY@#$D/ttyRTU#" "$O/brakefitd.toml.in" > "$D/brakefitd.toml"
    "$BRAKEFITD" -c "$D/brakefitd.toml" > "$O/daemon.log" 2>&1 &
    dpid=$!
    wait_port "$dpid" || { say "gpio: daemon does not answer: $(tail -3 "$O/daemon.log")"; fail=1; }
    sleep 0.5
    touch "$D/go"
    say "gpio: playing (time x$GPIO_SCALE)"
    for _ in $(seq 1 600); do grep -q '^PLAY' "$O/player.txt" && break; sleep 0.2; done
    say "gpio: $(cat "$O/player.txt")"
    wait_event 60 "$dpid" || { say "gpio: no event published"; fail=1; }
    mbread "$O/regs_event.txt"
    stop_daemon "$dpid"; wait "$dpid" 2>/dev/null
    kill "$ppid" 2>/dev/null; wait "$ppid" 2>/dev/null
    cat "$D"/rec/*.log > "$O/recorded.log" 2>/dev/null
    say "gpio: done"
  fi
  if [ -n "${CHIP:-}" ]; then
    # Edge loss of the project's reader as it is delayed, both uAPIs.
    O=$VB_OUT/edges; mkdir -p "$O"; : > "$O/edges.txt"
    for period in $EDGE_PERIODS_US; do
      for uapi in v1 v2; do
        for delay in 0 1 3 10; do
          "$PLAYER" edges "/dev/$CHIP" "$SIM" "$uapi" "$EDGE_COUNT" "$period" "$delay" \
            >> "$O/edges.txt" 2>&1
        done
      done
    done
    # The v2 FIFO shrunk to 16 events and a 10 ms reader: the loss must be reported.
    "$PLAYER" edges "/dev/$CHIP" "$SIM" v2 "$EDGE_COUNT" 250 10 16 >> "$O/edges.txt" 2>&1
    say "edges: $(wc -l < "$O/edges.txt") runs"
  fi
fi
say "guest done (rc $fail)"
exit $fail
