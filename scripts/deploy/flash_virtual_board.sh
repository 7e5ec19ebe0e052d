#!/usr/bin/env bash
# `deltactl flash` without --dry-run (CTest Deploy.FlashVirtualBoard, full build only): a stand-in
# `iceprog` on PATH records its arguments, and `deltactl virtual-board` on a pseudo-terminal is the
# board that comes back. Checks: the programmer ran exactly once with the bitstream as its only
# argument, and flash verified the board's identify against the bitstream's identify.mem (exit 0);
# with a board holding other weights than the bitstream (WEIGHTS with one output bias changed),
# flash fails (exit 1) after programming. The bitstream is an empty design of the UP5K's layout
# (BLANK_BITSTREAM_TOOL): flash refuses anything that is not an iCE40 UP5K bitstream.
# Usage: scripts/deploy/flash_virtual_board.sh DELTACTL WEIGHTS BLANK_BITSTREAM_TOOL
set -euo pipefail
deltactl=${1:?usage: flash_virtual_board.sh DELTACTL WEIGHTS BLANK_BITSTREAM_TOOL}
weights=${2:?usage: flash_virtual_board.sh DELTACTL WEIGHTS BLANK_BITSTREAM_TOOL}
blank_tool=${3:?usage: flash_virtual_board.sh DELTACTL WEIGHTS BLANK_BITSTREAM_TOOL}
fail() { echo "FAIL: $*" >&2; exit 1; }
work=$(mktemp -d)
board_pid=""
stop_board() {
  if [[ -n "$board_pid" ]]; then kill "$board_pid" 2>/dev/null || true; wait "$board_pid" 2>/dev/null || true; fi
  board_pid=""
}
trap 'stop_board; rm -rf "$work"' EXIT
start_board() {  # start_board WEIGHTS
  rm -f "$work/ready"; mkfifo "$work/ready"
  "$deltactl" virtual-board --link "$work/tty" --weights "$1" >"$work/ready" 2>"$work/board.err" &
  board_pid=$!
  read -r -t 60 ready <"$work/ready" || fail "virtual board not ready: $(cat "$work/board.err")"
  cat "$work/ready" >/dev/null &
}
mkdir "$work/bin" "$work/bits"
printf '#!/bin/sh\necho "$@" >>"%s/programmer.log"\n' "$work" >"$work/bin/iceprog"
chmod +x "$work/bin/iceprog"
"$deltactl" quantise --weights "$weights" --out-dir "$work/bits" >/dev/null 2>"$work/quantise.err" ||
  fail "quantise: $(cat "$work/quantise.err")"
"$blank_tool" "$work/bits/icebreaker_top.bin"
printf '[board]\nport = %s\n[network]\nweights = %s\nbitstream = bits/icebreaker_top.bin\n' "$work/tty" "$weights" \
  >"$work/deltactl.conf"

start_board "$weights"
PATH="$work/bin:$PATH" "$deltactl" flash --config "$work/deltactl.conf" --wait 5 >"$work/out" 2>&1 ||
  fail "flash: $(cat "$work/out")"
[[ "$(cat "$work/programmer.log")" == "$work/bits/icebreaker_top.bin" ]] ||
  fail "programmer arguments: $(cat "$work/programmer.log")"
grep -q '^flash: verified$' "$work/out" || fail "not verified: $(cat "$work/out")"
stop_board

other="$work/other.json"
python3 -c 'import json, sys
w = json.load(open(sys.argv[1])); w["output_bias"][0] += 0.01; json.dump(w, open(sys.argv[2], "w"))' "$weights" "$other"
start_board "$other"  # the board comes back with other weights than the bitstream's
status=0
PATH="$work/bin:$PATH" "$deltactl" flash --config "$work/deltactl.conf" --wait 2 >"$work/out2" 2>&1 || status=$?
[[ $status -eq 1 ]] || fail "flash against a board of other weights: exit $status: $(cat "$work/out2")"
grep -q "the board's identify differs from the bitstream's" "$work/out2" || fail "$(cat "$work/out2")"
echo "PASS: flash ran the programmer once and verified the board; a board of other weights fails"
