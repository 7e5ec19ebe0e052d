#!/usr/bin/env bash
# Benchmark (not a CTest test): peak resident memory of train, diagnose, cosim and accuracy on their
# default inputs (measured by /usr/bin/time's maximum RSS).
# Usage: scripts/bench_memory.sh [BUILD_DIR]. Prints a Markdown table.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
deltactl="$build/bin/deltactl"
[[ -x $deltactl ]] || { echo "bench_memory: $deltactl missing: bash scripts/build.sh" >&2; exit 2; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$deltactl" simulate --experiment validation --effects "$root/sim/paper_like_effects.json" --seed 1 --out "$work/fit.csv" 2>/dev/null
"$deltactl" simulate --experiment sweep --effects "$root/sim/paper_like_effects.json" --seed 7 --out "$work/check.csv" 2>/dev/null
peak() {  # peak RSS in MB of one command
  /usr/bin/time -f "%M" -o "$work/rss" "$@" >/dev/null 2>&1 || true
  awk '{ printf "%.1f", $1 / 1024 }' "$work/rss"
}
echo "| command | input | peak RSS [MB] |"
echo "|---|---|---|"
echo "| train | paper-like validation run, 13333 rows | $(peak "$deltactl" train --data "$work/fit.csv" --out "$work/w.json") |"
echo "| diagnose | the same + sweep seed 7 | $(peak "$deltactl" diagnose --data "$work/fit.csv" --holdout "$work/check.csv" --json "$work/d.json" --predictions "$work/p.csv") |"
echo "| cosim | shipped weights, experiment1, 1 s | $(peak "$deltactl" cosim --weights "$root/weights/paper_like.json" --duration 1) |"
echo "| accuracy | shipped weights, defaults | $(peak "$deltactl" accuracy --weights "$root/weights/paper_like.json") |"
