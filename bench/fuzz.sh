#!/usr/bin/env bash
# Runs every libFuzzer target for MINUTES each (default 5) in a Clang ASan+UBSan build
# (build/fuzz), from its seed corpus and the regression corpus, and prints executions and
# findings per target. A finding (crash, sanitizer report, timeout, leak) is left in
# build/fuzz/findings/TARGET/: minimise it, add it to tests/fuzz/regressions/TARGET/, fix.
#   bench/fuzz.sh [MINUTES] [TARGET...]
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
MINUTES=${1:-5}
shift || true
TARGETS=("$@")
[ ${#TARGETS[@]} -eq 0 ] && TARGETS=(candump curve_csv event_csv toml dbc model modbus_gate)
SECS=$(awk "BEGIN { s = int($MINUTES * 60); print (s < 1 ? 1 : s) }")
BUILD=$ROOT/build/fuzz
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
cmake -S "$ROOT" -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ \
  -DBRAKEFIT_WERROR=ON -DBRAKEFIT_SANITIZE=ON -DBRAKEFIT_ONLY_CORE_TESTS=ON -DBRAKEFIT_FUZZ=ON \
  "${launcher[@]}" >/dev/null
cmake --build "$BUILD" --parallel "$(nproc)" --target "${TARGETS[@]/#/fuzz_}"
export ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1
printf '%-12s %10s %12s %8s %9s %s\n' target seconds executions exec/s coverage findings
total_findings=0
for t in "${TARGETS[@]}"; do
  work=$BUILD/corpus/$t findings=$BUILD/findings/$t
  mkdir -p "$work" "$findings"
  log=$BUILD/fuzz_$t.log
  set +e
  "$BUILD/tests/fuzz/fuzz_$t" "$work" "$BUILD/tests/fuzz/seeds/$t" "$ROOT/tests/fuzz/regressions/$t" \
    -max_total_time=$SECS -timeout=10 -rss_limit_mb=2048 -max_len=65536 \
    -artifact_prefix="$findings/" -print_final_stats=1 >"$log" 2>&1
  set -e
  execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$log" | tail -1)
  cov=$(grep -o 'cov: [0-9]*' "$log" | tail -1 | awk '{print $2}')
  n=$(find "$findings" -type f | wc -l)
  total_findings=$((total_findings + n))
  printf '%-12s %10s %12s %8s %9s %s\n' "$t" "$SECS" "${execs:-?}" "${rate:-?}" "${cov:-?}" "$n"
  [ "$n" -gt 0 ] && grep -m3 -E 'ERROR|SUMMARY|==[0-9]+==' "$log" | sed 's/^/    /'
done
echo "findings: $total_findings (logs: $BUILD/fuzz_TARGET.log)"
[ "$total_findings" -eq 0 ]
