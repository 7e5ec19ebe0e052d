#!/usr/bin/env bash
# A profile-guided build of deltactl (a benchmark build, not the default): builds BUILD_DIR
# instrumented (DELTA_PGO=generate), trains it on co-simulations through both virtual boards
# (TRAIN_SECONDS of experiment 1 on the RTL board; ten times as long on the model board, of
# experiment 1 with the deployed model and of the validation trajectory with the plain network),
# then rebuilds it with the profiles (DELTA_PGO=use). Both builds also link-time optimised; not for
# this machine's processor (-march=native changes Eigen's vector reductions and fused multiply-adds
# the world's floating-point bits: as built here, the recordings equal the default build's). Compare with
#   bash scripts/bench_boards.sh BUILD_DIR 2 5 build
# Usage: scripts/build_pgo.sh [BUILD_DIR] [TRAIN_SECONDS]   (defaults: build-pgo, 0.5)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build-pgo}
seconds=${2:-0.5}
bash "$root/scripts/setup.sh"
profiles="$build/pgo"
echo "build_pgo: instrumented build in $build" >&2
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DDELTA_PGO=generate -DDELTA_PGO_DIR="$profiles" \
  -DCMAKE_INTERPROCEDURAL_OPTIMIZATION=ON -DCMAKE_CXX_FLAGS= >/dev/null
rm -rf "$profiles"
cmake --build "$build" --target deltactl
train() { # FIDELITY WEIGHTS TRAJECTORY SECONDS
  echo "build_pgo: training on $4 s of $3, $1 board ($2)" >&2
  "$build/bin/deltactl" cosim --fidelity "$1" --weights "$root/weights/$2" \
    --effects "$root/sim/paper_like_effects.json" --trajectory "$3" --duration "$4" >/dev/null
}
train rtl paper_like_deployed.json experiment1 "$seconds"
model_seconds=$(awk -v s="$seconds" 'BEGIN { print 10 * s }')
train model paper_like_deployed.json experiment1 "$model_seconds"
train model paper_like.json validation "$model_seconds"
[[ -n $(find "$profiles" -name '*.gcda' -print -quit 2>/dev/null) ]] ||
  { echo "build_pgo: error: no profile written to $profiles" >&2; exit 1; }
echo "build_pgo: rebuilt with the profiles" >&2
cmake -S "$root" -B "$build" -DDELTA_PGO=use >/dev/null
cmake --build "$build" --target deltactl
echo "build_pgo: $build/bin/deltactl" >&2
