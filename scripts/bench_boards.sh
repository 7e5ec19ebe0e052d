#!/usr/bin/env bash
# Benchmark (not a CTest test): both virtual boards' speed in the same run, on the whole-robot
# co-simulation (`deltactl cosim`, experiment 1, paper-like robot): the Verilated board core (RTL
# fidelity) and the C++ model board (model fidelity, bit-exact with it), each as board cycles per
# second and as a multiple of real time (rtl/board/delta_board_pkg.sv BoardClockHz), median of RUNS
# runs, then their ratio. The model runs free here (cosim never paces). BASELINE_BUILD (optional):
# another build (e.g. of an older commit) whose two boards are measured in the same run, and the
# ratios of this build's boards to its.
# Usage: scripts/bench_boards.sh [BUILD_DIR] [SECONDS] [RUNS] [BASELINE_BUILD]   (defaults: build, 2, 3, none)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
seconds=${2:-2}
runs=${3:-3}
baseline=${4:-}
deltactl="$build/bin/deltactl"
[[ -z $baseline || -x $baseline/bin/deltactl ]] || { echo "bench_boards: $baseline/bin/deltactl missing" >&2; exit 2; }
[[ -x $deltactl ]] || { echo "bench_boards: $deltactl missing: bash scripts/build.sh" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
clock_mhz=$(awk '/localparam int BoardClockHz/ { gsub(/[_;]/, "", $7); print $7 / 1e6 }' "$root/rtl/board/delta_board_pkg.sv")

# median M board cycles/s of `deltactl cosim --fidelity $1` (deltactl $2, default this build's)
measure() {
  local fidelity=$1 program=${2:-$deltactl} rates=() rate run
  for ((run = 1; run <= runs; run++)); do
    "$program" cosim --fidelity "$fidelity" --weights "$root/weights/paper_like.json" \
      --effects "$root/sim/paper_like_effects.json" --trajectory experiment1 --duration "$seconds" \
      >/dev/null 2>"$work/err" || true
    rate=$(sed -n 's/.*[( ]\([0-9.]*\) M board cycles\/s).*/\1/p' "$work/err" | tail -1)
    [[ -n $rate ]] || { echo "bench_boards: no speed line from --fidelity $fidelity:" >&2; tail -3 "$work/err" >&2; exit 1; }
    rates+=("$rate")
  done
  echo "${rates[*]}"
}
median() { printf '%s\n' "$@" | sort -g | awk '{ a[NR] = $1 } END { print a[int((NR + 1) / 2)] }'; }

read -r -a rtl <<<"$(measure rtl)"
read -r -a model <<<"$(measure model)"
if [[ -n $baseline ]]; then
  read -r -a base_rtl <<<"$(measure rtl "$baseline/bin/deltactl")"
  read -r -a base <<<"$(measure model "$baseline/bin/deltactl")"
fi
rtl_median=$(median "${rtl[@]}")
model_median=$(median "${model[@]}")
x() { awk -v r="$1" -v c="$clock_mhz" 'BEGIN { printf "%.3f", r / c }'; }
echo "| board | runs | M board cycles/s (each) | median | x real time (${clock_mhz} MHz board clock) |"
echo "|---|---|---|---|---|"
echo "| RTL (Verilated board_core) | $runs | ${rtl[*]} | $rtl_median | $(x "$rtl_median") |"
echo "| model (C++ model board) | $runs | ${model[*]} | $model_median | $(x "$model_median") |"
if [[ -n $baseline ]]; then
  base_rtl_median=$(median "${base_rtl[@]}")
  base_median=$(median "${base[@]}")
  echo "| RTL, baseline build ($baseline) | $runs | ${base_rtl[*]} | $base_rtl_median | $(x "$base_rtl_median") |"
  echo "| model, baseline build ($baseline) | $runs | ${base[*]} | $base_median | $(x "$base_median") |"
fi
ratio() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.2f", a / b }'; }
echo "model / RTL: $(ratio "$model_median" "$rtl_median") x"
if [[ -n $baseline ]]; then
  echo "RTL / baseline RTL: $(ratio "$rtl_median" "$base_rtl_median") x"
  echo "model / baseline model: $(ratio "$model_median" "$base_median") x"
fi
