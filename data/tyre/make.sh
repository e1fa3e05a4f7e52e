#!/usr/bin/env bash
# Regenerates the shipped tyre curves: data/tyre/make.sh [path/to/brakefit]
# One MF 6.1 tyre (the second simulator's tno_205_60r15.tir) at three wheel loads and two inflation
# pressures, slip to 1.0, 1 % noise: what a tyre laboratory's drum or flat-track gives.
set -euo pipefail
bf=${1:-build/release/cli/brakefit}
d=$(dirname "$0")
tir="$d/../../sim/second/tyres/tno_205_60r15.tir"
seed=40
for load in 2400 4000 5600; do
  for bar in 2.2 2.6; do
    seed=$((seed + 1))
    "$bf" synth --tir "$tir" --wheel-load-n "$load" --tyre-pressure-bar "$bar" --slip-max 1.0 \
      --points 200 --noise 0.01 --seed "$seed" --out "$d/tno_${load}n_${bar/./p}bar.csv"
  done
done
