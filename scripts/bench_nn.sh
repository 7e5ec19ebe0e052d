#!/usr/bin/env bash
# Benchmark of the float network: training time to convergence on the 13333-sample validation run of
# the paper-like robot (seeds 1..3; deployed, network, hybrid), and inference time per pose against the closed-form kinematics.
# BUILD selects the build folder (default build/). Prints Markdown tables.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=$(cd "$root" && mkdir -p "${BUILD:-build}" && cd "${BUILD:-build}" && pwd)
if [[ ! -f "$build/CMakeCache.txt" ]]; then bash "$root/scripts/build.sh" --target deltactl; fi
cmake --build "$build" -j2 --target deltactl bench_nn_inference >/dev/null
deltactl="$build/bin/deltactl"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$deltactl" simulate --experiment validation --effects "$root/sim/paper_like_effects.json" --seed 1 \
  --out "$work/fit.csv" 2>/dev/null
echo "Training: deltactl train on 13333 samples (paper-like validation run), $(nproc) cores"
echo
echo "| model | seed | epochs | stopped by | validation RMSE [deg] | wall time [s] | CPU time [s] |"
echo "|---|---|---|---|---|---|---|"
for model in deployed network hybrid; do
  for seed in 1 2 3; do
    /usr/bin/time -f "%e %U %S" -o "$work/time" \
      "$deltactl" train --model "$model" --data "$work/fit.csv" --out "$work/w.json" --seed "$seed" 2>"$work/log"
    read -r wall user system <"$work/time"
    summary=$(grep ' epochs, stopped by ' "$work/log")
    epochs=$(sed -E 's/.*\), ([0-9]+) epochs.*/\1/' <<<"$summary")
    stop=$(sed -E 's/.*stopped by ([a-z_]+).*/\1/' <<<"$summary")
    rmse=$(sed -E 's/.*validation RMSE ([0-9.]+) deg.*/\1/' <<<"$summary")
    cpu=$(awk -v u="$user" -v s="$system" 'BEGIN { printf "%.1f", u + s }')
    echo "| $model | $seed | $epochs | $stop | $rmse | $wall | $cpu |"
  done
done
echo
"$build/bin/bench_nn_inference" "$root/weights/paper_like.json"
