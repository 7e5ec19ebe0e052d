#!/usr/bin/env bash
# CTest Deploy.WeightsPipeline: scripts/deploy_weights.sh from a recording to a board holding the
# new model. A 2000-sample validation run of the paper-like robot is recorded, retrained, scored on
# a held-out sweep and quantised (the ROM files those `deltactl quantise` gives for that W.json),
# and without --port the load command is printed; then, for the shipped weights (--weights), onto a
# virtual board started with no model (--port): the board then holds that model (`host status`:
# its CRC as quantise prints it), and identify.mem is the one the build's gateware carries (the
# same for every model).
# Usage: scripts/deploy/weights_pipeline_test.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src=${1:?usage: weights_pipeline_test.sh SOURCE_DIR BUILD_DIR}
build=${2:?usage: weights_pipeline_test.sh SOURCE_DIR BUILD_DIR}
fail() { echo "FAIL: $*" >&2; exit 1; }
work=$(mktemp -d)
board_pid=""
trap 'if [[ -n $board_pid ]]; then kill "$board_pid" 2>/dev/null || true; wait "$board_pid" 2>/dev/null || true; fi; rm -rf "$work"' EXIT
deltactl=$build/bin/deltactl
"$deltactl" simulate --experiment validation --samples 2000 --effects "$src/sim/paper_like_effects.json" \
  --out "$work/fit.csv" 2>/dev/null
"$deltactl" simulate --experiment sweep --samples 500 --seed 7 --effects "$src/sim/paper_like_effects.json" \
  --out "$work/check.csv" 2>/dev/null
DELTACTL=$deltactl bash "$src/scripts/deploy_weights.sh" --data "$work/fit.csv" --holdout "$work/check.csv" \
  --out-dir "$work/new" >"$work/log" 2>&1 || { cat "$work/log" >&2; fail "deploy_weights.sh"; }
grep -q "^deltactl host load --port PORT --weights $work/new/W.json$" "$work/log" ||
  { cat "$work/log" >&2; fail "no load command printed"; }
grep -q "held-out" "$work/log" || grep -qi "table 1" "$work/log" || { cat "$work/log" >&2; fail "no Table 1"; }
[[ -s $work/new/W.json ]] || fail "no W.json"
mkdir "$work/again"
"$deltactl" quantise --weights "$work/new/W.json" --out-dir "$work/again" >/dev/null
for file in "$work"/again/*.mem; do
  cmp -s "$file" "$work/new/mem/$(basename "$file")" || fail "$(basename "$file") differs from deltactl quantise"
done
mkfifo "$work/ready"
"$deltactl" virtual-board --link "$work/tty" --fidelity model --no-model >"$work/ready" 2>"$work/board.err" &
board_pid=$!
read -r -t 60 ready <"$work/ready" || fail "virtual board not ready: $(cat "$work/board.err")"
cat "$work/ready" >/dev/null &
DELTACTL=$deltactl bash "$src/scripts/deploy_weights.sh" --weights "$src/weights/paper_like_deployed.json" \
  --out-dir "$work/shipped" --port "$work/tty" >"$work/log2" 2>&1 || { cat "$work/log2" >&2; fail "deploy_weights.sh --port"; }
crc=$(sed -n 's/.*weights CRC-32 \([0-9a-f]\{8\}\).*/\1/p' "$work/log2" | head -1)
[[ -n $crc ]] || fail "quantise printed no CRC: $(cat "$work/log2")"
grep -q "^load: model $crc " "$work/log2" || { cat "$work/log2" >&2; fail "no load of model $crc"; }
grep -q "^model: loaded, weights CRC $crc$" "$work/log2" || { cat "$work/log2" >&2; fail "the board does not hold $crc"; }
if [[ -f $build/rtl/network/mem/identify.mem ]]; then
  cmp -s "$work/shipped/mem/identify.mem" "$build/rtl/network/mem/identify.mem" ||
    fail "identify.mem of the shipped weights differs from the build's gateware"
fi
echo "PASS: retrained on 2000 samples, scored on 500 held out, quantised ($(ls "$work"/new/mem/*.mem | wc -l) ROM files);" \
  "the shipped model $crc loaded onto a board that had none"
