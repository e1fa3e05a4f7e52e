#!/usr/bin/env bash
# Regenerates the shipped bench measurement model: data/bench_models/make.sh [path/to/brakefit]
# The roller bench of data/recorded/, measured once on its three 2.2 bar runs (brakefit gap
# --bench-model); replay, compare, fit and brakefitd apply it to that bench's other events.
set -euo pipefail
bf=$(realpath "${1:-build/release/cli/brakefit}")
cd "$(dirname "$0")/../.."
"$bf" gap --bench-model data/bench_models/roller.bench.toml \
  data/recorded/roller_2p2bar_slow.log data/recorded/roller_2p2bar_medium.log \
  data/recorded/roller_2p2bar_fast.log >/dev/null
