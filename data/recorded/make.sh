#!/usr/bin/env bash
# Regenerates the shipped recorded tests (deterministic): data/recorded/make.sh [path/to/brakefit]
# Roller (paper Test 1) and flat ground (Test 2), tyre at 1 bar and at the nominal 2.2 bar (as in
# the paper), three pedal ramp rates each. Each log has <stem>.bench.toml (calibration) and
# <stem>.truth.json (ground truth) beside it.
set -euo pipefail
bf=${1:-build/release/cli/brakefit}
root=$(cd "$(dirname "$0")/../.." && pwd)
d="$root/data/recorded"
seed=100
for p in 1.0 2.2; do
  for ramp in slow medium fast; do
    seed=$((seed + 1))
    "$bf" simulate "$root/sim/scenarios/roller_car.toml" --ramp "$ramp" --tyre-pressure "$p" --seed "$seed" \
      --out "$d/roller_${p/./p}bar_${ramp}.log"
  done
  for ramp in 100 150 250; do
    seed=$((seed + 1))
    "$bf" simulate "$root/sim/scenarios/ground_car.toml" --ramp "$ramp" --tyre-pressure "$p" --seed "$seed" \
      --out "$d/ground_${p/./p}bar_${ramp}barps.log"
  done
done
