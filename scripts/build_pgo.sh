#!/usr/bin/env bash
# A profile-guided build of deltactl's Verilated models (benchmark build, not the default): builds
# BUILD_DIR with the models instrumented (DELTA_RTL_PGO=generate), trains them on a co-simulation
# of experiment 1 through the RTL board (TRAIN_SECONDS of it), then rebuilds them with the profiles
# (DELTA_RTL_PGO=use). The rest of the build is the usual Release. Compare with
#   bash scripts/bench_boards.sh BUILD_DIR 2 3 build
# Usage: scripts/build_pgo.sh [BUILD_DIR] [TRAIN_SECONDS]   (defaults: build-pgo, 0.5)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build-pgo}
seconds=${2:-0.5}
bash "$root/scripts/setup.sh"
profiles="$build/rtl-pgo"
echo "build_pgo: instrumented models in $build" >&2
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DDELTA_RTL_PGO=generate \
  -DDELTA_RTL_PGO_DIR="$profiles" >/dev/null
rm -rf "$profiles"
cmake --build "$build" --target deltactl
echo "build_pgo: training on $seconds s of experiment 1 (RTL board)" >&2
"$build/bin/deltactl" cosim --fidelity rtl --weights "$root/weights/paper_like_deployed.json" \
  --effects "$root/sim/paper_like_effects.json" --trajectory experiment1 --duration "$seconds" >/dev/null
[[ -n $(find "$profiles" -name '*.gcda' -print -quit 2>/dev/null) ]] ||
  { echo "build_pgo: error: no profile written to $profiles" >&2; exit 1; }
echo "build_pgo: models rebuilt with the profiles" >&2
cmake -S "$root" -B "$build" -DDELTA_RTL_PGO=use >/dev/null
cmake --build "$build" --target deltactl
echo "build_pgo: $build/bin/deltactl" >&2
