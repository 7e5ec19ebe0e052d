#!/usr/bin/env bash
# Benchmark (not a CTest test): the HLS C-simulation (sc_fixed) against the golden model on
# 1,000,000 vectors of the shipped weights (corners, grid, random in and beyond the trained range,
# random raw codes), then the synthesis top on 1,000,000 golden vectors. About 2 x 150 s on one core.
# Usage: scripts/bench_hls_csim.sh [BUILD_DIR] [VECTORS]
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$root/build}"
vectors="${2:-1000000}"
cmake --build "$build" -j2 --target fixed_point_tests network_top_tb
DELTA_CSIM_VECTORS="$vectors" "$build/tests/fixed_point_tests" \
  --gtest_filter='HlsCsim.EveryRawCodeMatchesGoldenOnShippedWeights'
export_dir="$(mktemp -d)"
trap 'rm -rf "$export_dir"' EXIT
"$build/bin/deltactl" quantise --weights "$root/weights/paper_like.json" --out-dir "$export_dir" --vectors "$vectors" >/dev/null
# The top was compiled with the same weights (build/tests/fixed_point_export), so the vectors apply.
"$build/tests/network_top_tb" "$export_dir/golden_vectors.txt"
