#!/usr/bin/env bash
# Benchmark (not a CTest test): speed of the whole-robot co-simulation around the Verilated board
# core as built (the virtual board at RTL fidelity), as board cycles per second and as a multiple of
# real time (rtl/board/delta_board_pkg.sv BoardClockHz: 23.25 MHz), median of RUNS runs of `deltactl cosim` on
# experiment 1 with the paper-like robot.
# Usage: scripts/bench_cosim.sh [BUILD_DIR] [SECONDS] [RUNS]   (defaults: build, 2, 3)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
seconds=${2:-2}
runs=${3:-3}
deltactl="$build/bin/deltactl"
[[ -x $deltactl ]] || { echo "bench_cosim: $deltactl missing: bash scripts/build.sh" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
rates=()
for ((run = 1; run <= runs; run++)); do
  "$deltactl" cosim --weights "$root/weights/paper_like.json" --effects "$root/sim/paper_like_effects.json" \
    --trajectory experiment1 --duration "$seconds" >/dev/null 2>"$work/err" || true
  rate=$(sed -n 's/.*[( ]\([0-9.]*\) M board cycles\/s).*/\1/p' "$work/err" | tail -1)
  [[ -n $rate ]] || { echo "bench_cosim: no speed line in the output:" >&2; tail -3 "$work/err" >&2; exit 1; }
  rates+=("$rate")
done
median=$(printf '%s\n' "${rates[@]}" | sort -g | awk '{ a[NR] = $1 } END { print a[int((NR + 1) / 2)] }')
clock_mhz=$(awk '/localparam int BoardClockHz/ { gsub(/[_;]/, "", $7); print $7 / 1e6 }' "$root/rtl/board/delta_board_pkg.sv")
echo "| board | runs | M board cycles/s (each) | median | x real time (${clock_mhz} MHz board clock) |"
echo "|---|---|---|---|---|"
echo "| RTL (Verilated board_core) | $runs | ${rates[*]} | $median | $(awk -v r="$median" -v c="$clock_mhz" 'BEGIN { printf "%.3f", r / c }') |"
