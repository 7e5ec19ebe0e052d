#!/usr/bin/env bash
# The main job on built-in defaults: the paper's validation experiment on the simulated
# (paper-like) robot, and the math model's error against it (Table 1 layout, Fig. 4/5 plot).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
bash scripts/build.sh --target deltactl
out=build/run
mkdir -p "$out"
deltactl=build/bin/deltactl
echo "== Validation experiment on the paper-like virtual robot (sim/paper_like_effects.json)"
$deltactl simulate --experiment validation --effects sim/paper_like_effects.json --seed 1 --out "$out/validation.csv"
echo
$deltactl compare --data "$out/validation.csv" --plot "$out/validation_errors.png"
echo
echo "Outputs in $out/"
