#!/usr/bin/env bash
# The virtual bench (ctest label vbench): tests/vbench/run.sh BUILD_DIR
# 1. kernel.sh: the archive's current Debian kernel, gpio-sim.ko, the initramfs (cached in
#    $BRAKEFIT_VBENCH_CACHE, default ~/.cache/brakefit/vbench); exit 77 = skipped, says why.
# 2. prepare.py: the scenario inputs and daemon configs in BUILD_DIR/vbench.
# 3. QEMU (TCG, 1 vCPU: on 2 the kernel merges edges under TCG) boots it; guest.sh runs the
#    scenarios with BUILD_DIR's binaries over the 9p-shared host root. -icount shift=3,sleep=off:
#    guest time counts executed instructions and skips idle time, so neither host load nor host
#    hiccups move an edge in guest time (other tests may run beside it).
# 4. check.py compares the guest's figures with `brakefit replay` and fails on any mismatch.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
BUILD=$(cd "${1:?usage: run.sh BUILD_DIR}" && pwd)
VB=${BRAKEFIT_VBENCH_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/brakefit/vbench}
t_start=$(date +%s.%N)
bash "$HERE/kernel.sh" "$VB" > "$BUILD/vbench-kernel.log" 2>&1 || {
  rc=$?; tail -5 "$BUILD/vbench-kernel.log"; exit $rc; }
tail -2 "$BUILD/vbench-kernel.log"
KVER=$(cat "$VB/kver")
K=$VB/k/$KVER
OUT=$BUILD/vbench
rm -rf "$OUT"; mkdir -p "$OUT"
PY=/usr/bin/python3
GPIO_SCALE=${VBENCH_GPIO_SCALE:-6}
$PY "$HERE/prepare.py" "$ROOT" "$BUILD/cli/brakefit" "$OUT" "$GPIO_SCALE"
cat > "$OUT/env.sh" <<EOF
VB_OUT=$OUT
KVER=$KVER
KROOT=$K/root
GPIOSIM_KO=$K/mod/gpio-sim.ko
BRAKEFITD=$BUILD/daemon/brakefitd
PLAYER=$BUILD/tests/vbench/bench_player
GPIO_SCALE=$GPIO_SCALE
CAN_BURST=${VBENCH_CAN_BURST:-5000}
EDGE_COUNT=${VBENCH_EDGE_COUNT:-2000}
EDGE_PERIODS_US="${VBENCH_EDGE_PERIODS_US:-250 125}"
VB_ONLY=${VBENCH_ONLY:-}
EOF
t_boot=$(date +%s.%N)
set +e
timeout 300 qemu-system-x86_64 -accel tcg -cpu max ${VBENCH_QEMU_EXTRA--icount shift=3,sleep=off} -smp 1 -m 1024 -nographic -no-reboot \
  -kernel "$K/root/boot/vmlinuz-$KVER" -initrd "$K/initramfs.cpio.gz" \
  -append "console=ttyS0 quiet loglevel=4 panic=-1 vb_script=$HERE/guest.sh vb_rc=$OUT/rc vb_env=$OUT/env.sh" \
  -fsdev local,id=r,path=/,security_model=none,multidevs=remap \
  -device virtio-9p-pci,fsdev=r,mount_tag=hostroot < /dev/null > "$OUT/console.log" 2>&1
qrc=$?
set -e
t_end=$(date +%s.%N)
grep -E '^(VB|vbench-init):' "$OUT/console.log" || true
if [ "$qrc" -ne 0 ]; then
  echo "vbench: qemu exited $qrc (124: the 300 s limit); console in $OUT/console.log"
  tail -20 "$OUT/console.log"
  exit 1
fi
[ -f "$OUT/rc" ] || { echo "vbench: the guest did not finish (no $OUT/rc)"; tail -20 "$OUT/console.log"; exit 1; }
echo "vbench: guest rc $(cat "$OUT/rc"); qemu $(echo "$t_end - $t_boot" | bc) s, whole run $(echo "$t_end - $t_start" | bc) s"
$PY "$HERE/check.py" "$ROOT" "$BUILD" "$OUT" "$GPIO_SCALE"
