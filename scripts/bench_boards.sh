#!/usr/bin/env bash
# Benchmark (not a CTest test): both virtual boards' speed in the same run, on the whole-robot
# co-simulation (`deltactl cosim`, experiment 1, paper-like robot): the Verilated board core (RTL
# fidelity) and the C++ model board (model fidelity, bit-exact with it), each as board cycles per
# second and as a multiple of real time (rtl/board/delta_board_pkg.sv BoardClockHz), median of RUNS
# runs, then their ratio: the whole co-simulation (host, board, world, truth recording) and, where
# cosim reports it, the board and the world alone (its "alone" line: the wall time inside the
# virtual board, the observers excluded). The model runs free here (cosim never paces).
# BASELINE (optional): another build (e.g. of an older commit) whose two boards are measured in the
# same run, and the ratios of this build's boards to its; a build whose cosim has no --fidelity
# (before the model board, e.g. cbff4c4) has its RTL board only. BASELINE is
# a build directory, or a commit of this repository: then its default build in
# build-baseline-COMMIT/src/build (a git worktree, built once, deltactl only).
# Usage: scripts/bench_boards.sh [BUILD_DIR] [SECONDS] [RUNS] [BASELINE]   (defaults: build, 2, 3, none)
#   e.g. bash scripts/build_pgo.sh && bash scripts/bench_boards.sh build-pgo 2 5 cbff4c4
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
seconds=${2:-2}
runs=${3:-3}
baseline=${4:-}
deltactl="$build/bin/deltactl"
if [[ -n $baseline && ! -d $baseline ]]; then
  commit=$(git -C "$root" rev-parse --verify --quiet "$baseline^{commit}") ||
    { echo "bench_boards: $baseline is neither a build directory nor a commit" >&2; exit 2; }
  tree="$root/build-baseline-${commit:0:7}/src"
  if [[ ! -x $tree/build/bin/deltactl ]]; then
    echo "bench_boards: building $baseline (${commit:0:7}) in $tree/build" >&2
    [[ -d $tree ]] || git -C "$root" worktree add --detach "$tree" "$commit" >&2
    cmake -S "$tree" -B "$tree/build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
    cmake --build "$tree/build" --target deltactl >&2
  fi
  baseline="$tree/build"
fi
[[ -z $baseline || -x $baseline/bin/deltactl ]] || { echo "bench_boards: $baseline/bin/deltactl missing" >&2; exit 2; }
[[ -x $deltactl ]] || { echo "bench_boards: $deltactl missing: bash scripts/build.sh" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# The simulated board clock of a source tree [MHz]: its co-simulation's clocks per 10 kHz period
# (SimClocksPerPeriod where the simulation ran a shorter period than the board, before the play shift).
clock_of() {
  awk '/localparam int BoardClockHz/ { gsub(/[_;]/, "", $7); board = $7 / 1e6 }
       /localparam int SimClocksPerPeriod/ { gsub(/[_;]/, "", $7); sim = $7 / 100 }
       END { print sim ? sim : board }' "$1/rtl/board/delta_board_pkg.sv"
}
clock_mhz=$(clock_of "$root")

# M board cycles/s of RUNS runs of `deltactl cosim --fidelity $1` (deltactl $2, default this
# build's): the whole co-simulation's, then (after "|") the board and world alone ("-" if not reported)
measure() {
  local fidelity=$1 program=${2:-$deltactl} rates=() alone=() rate run choice=()
  # (a build before the model board: the RTL board without the option)
  [[ $("$program" cosim --help) != *--fidelity* ]] || choice=(--fidelity "$fidelity")
  for ((run = 1; run <= runs; run++)); do
    "$program" cosim "${choice[@]}" --weights "$root/weights/paper_like.json" \
      --effects "$root/sim/paper_like_effects.json" --trajectory experiment1 --duration "$seconds" \
      >/dev/null 2>"$work/err" || true
    rate=$(sed -n 's/.*[( ]\([0-9.]*\) M board cycles\/s).*/\1/p' "$work/err" | tail -1)
    [[ -n $rate ]] || { echo "bench_boards: no speed line from --fidelity $fidelity:" >&2; tail -3 "$work/err" >&2; exit 1; }
    rates+=("$rate")
    rate=$(sed -n 's/.*alone: .* \([0-9.]*\) M board cycles\/s, .*/\1/p' "$work/err" | tail -1)
    alone+=("${rate:--}")
  done
  echo "${rates[*]} | ${alone[*]}"
}
median() { printf '%s\n' "$@" | sort -g | awk '{ a[NR] = $1 } END { print a[int((NR + 1) / 2)] }'; }

split() { # "a b | c d" -> the whole runs (part 1) or the alone runs (part 2)
  local text=$1 part=$2
  if [[ $part == 1 ]]; then echo "${text%% |*}"; else echo "${text##*| }"; fi
}
rtl_all=$(measure rtl)
model_all=$(measure model)
base_has_model=false
if [[ -n $baseline ]]; then
  base_rtl_all=$(measure rtl "$baseline/bin/deltactl")
  if [[ $("$baseline/bin/deltactl" cosim --help) == *--fidelity* ]]; then
    base_has_model=true
    base_all=$(measure model "$baseline/bin/deltactl")
  fi
fi
read -r -a rtl <<<"$(split "$rtl_all" 1)"
read -r -a model <<<"$(split "$model_all" 1)"
read -r -a model_alone <<<"$(split "$model_all" 2)"
read -r -a rtl_alone <<<"$(split "$rtl_all" 2)"
rtl_median=$(median "${rtl[@]}")
model_median=$(median "${model[@]}")
x() { [[ $1 == - ]] && { echo -; return; }; awk -v r="$1" -v c="${2:-$clock_mhz}" 'BEGIN { printf "%.3f", r / c }'; }
echo "| board | runs | M board cycles/s (each) | median | x real time (${clock_mhz} MHz board clock) |"
echo "|---|---|---|---|---|"
echo "| RTL (Verilated board_core), whole co-simulation | $runs | ${rtl[*]} | $rtl_median | $(x "$rtl_median") |"
if [[ ${rtl_alone[0]} != - ]]; then
  rtl_alone_median=$(median "${rtl_alone[@]}")
  echo "| RTL, the board and the world alone | $runs | ${rtl_alone[*]} | $rtl_alone_median | $(x "$rtl_alone_median") |"
fi
echo "| model (C++ model board), whole co-simulation | $runs | ${model[*]} | $model_median | $(x "$model_median") |"
if [[ ${model_alone[0]} != - ]]; then
  model_alone_median=$(median "${model_alone[@]}")
  echo "| model, the board and the world alone | $runs | ${model_alone[*]} | $model_alone_median | $(x "$model_alone_median") |"
fi
if [[ -n $baseline ]]; then
  read -r -a base_rtl <<<"$(split "$base_rtl_all" 1)"
  base_rtl_median=$(median "${base_rtl[@]}")
  base_source=$(sed -n 's/^CMAKE_HOME_DIRECTORY:INTERNAL=//p' "$baseline/CMakeCache.txt")
  base_clock_mhz=$(clock_of "$base_source")
  echo "| RTL, baseline build ($baseline), whole co-simulation | $runs | ${base_rtl[*]} | $base_rtl_median | $(x "$base_rtl_median" "$base_clock_mhz") (its ${base_clock_mhz} MHz) |"
  if $base_has_model; then
    read -r -a base <<<"$(split "$base_all" 1)"
    base_median=$(median "${base[@]}")
    echo "| model, baseline build ($baseline), whole co-simulation | $runs | ${base[*]} | $base_median | $(x "$base_median") |"
  fi
fi
ratio() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.2f", a / b }'; }
echo "model / RTL: $(ratio "$model_median" "$rtl_median") x"
if [[ -n $baseline ]]; then
  echo "RTL / baseline RTL: $(ratio "$rtl_median" "$base_rtl_median") x (board cycles per second)"
  if $base_has_model; then echo "model / baseline model: $(ratio "$model_median" "$base_median") x"; fi
fi
