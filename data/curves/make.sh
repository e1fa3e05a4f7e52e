#!/usr/bin/env bash
# Regenerates the shipped curves: data/curves/make.sh [path/to/brakefit]
set -euo pipefail
bf=${1:-build/release/cli/brakefit}
d=$(dirname "$0")
"$bf" synth --B 18 --C 1.60 --D 3200 --E 0.20 --slip-max 0.27 --points 150 --noise 0.01 --seed 11 --out "$d/roller_car_1bar.csv"
"$bf" synth --B 13 --C 1.62 --D 4300 --E 0.35 --slip-max 1.0 --points 200 --noise 0.01 --seed 12 --slip-unit percent --out "$d/ground_car_1bar.csv"
"$bf" synth --B 6 --C 1.40 --D 24000 --E -4 --slip-max 1.0 --points 200 --noise 0.01 --seed 13 --out "$d/truck_nominal.csv"
