#!/usr/bin/env bash
# CTest Deploy.WeightsPipeline: scripts/deploy_weights.sh up to the bitstream (--no-bitstream; the
# nextpnr run takes minutes and is measured in README.md instead). A 2000-sample validation run of
# the paper-like robot is recorded, retrained, scored on a held-out sweep and quantised; the
# quantised ROMs must be the ones `deltactl quantise` gives for that W.json, and for the shipped
# weights (--weights) the identify.mem must equal the one the build's board carries.
# Usage: scripts/deploy/weights_pipeline_test.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src=${1:?usage: weights_pipeline_test.sh SOURCE_DIR BUILD_DIR}
build=${2:?usage: weights_pipeline_test.sh SOURCE_DIR BUILD_DIR}
fail() { echo "FAIL: $*" >&2; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
deltactl=$build/bin/deltactl
"$deltactl" simulate --experiment validation --samples 2000 --effects "$src/sim/paper_like_effects.json" \
  --out "$work/fit.csv" 2>/dev/null
"$deltactl" simulate --experiment sweep --samples 500 --seed 7 --effects "$src/sim/paper_like_effects.json" \
  --out "$work/check.csv" 2>/dev/null
bash "$src/scripts/deploy_weights.sh" --data "$work/fit.csv" --holdout "$work/check.csv" --out-dir "$work/new" \
  --no-bitstream >"$work/log" 2>&1 || { cat "$work/log" >&2; fail "deploy_weights.sh"; }
grep -q "held-out" "$work/log" || grep -qi "table 1" "$work/log" || { cat "$work/log" >&2; fail "no Table 1"; }
[[ -s $work/new/W.json ]] || fail "no W.json"
mkdir "$work/again"
"$deltactl" quantise --weights "$work/new/W.json" --out-dir "$work/again" >/dev/null
for file in "$work"/again/*.mem; do
  cmp -s "$file" "$work/new/mem/$(basename "$file")" || fail "$(basename "$file") differs from deltactl quantise"
done
bash "$src/scripts/deploy_weights.sh" --weights "$src/weights/paper_like_deployed.json" --out-dir "$work/shipped" \
  --no-bitstream >"$work/log2" 2>&1 || { cat "$work/log2" >&2; fail "deploy_weights.sh --weights"; }
if [[ -f $build/rtl/network/mem/identify.mem ]]; then
  cmp -s "$work/shipped/mem/identify.mem" "$build/rtl/network/mem/identify.mem" ||
    fail "identify.mem of the shipped weights differs from the build's board"
fi
echo "PASS: retrained on 2000 samples, scored on 500 held out, quantised ($(ls "$work"/new/mem/*.mem | wc -l) ROM files);" \
  "the shipped weights' identify.mem is the board's"
