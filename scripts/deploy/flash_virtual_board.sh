#!/usr/bin/env bash
# `deltactl flash` without --dry-run (CTest Deploy.FlashVirtualBoard, full build only): a stand-in
# `iceprog` on PATH records its arguments, and `deltactl virtual-board` on a pseudo-terminal is the
# board that comes back. Checks: the programmer ran exactly once with the bitstream as its only
# argument, and flash verified the board's identify against the bitstream's gateware build id
# (identify.mem beside it; exit 0), with the hint to load the model; a bitstream of another gateware
# (its identify.mem's build id changed) is refused without --force, and with --force flash fails
# (exit 1) after programming when the board comes back with this build's gateware. The bitstream is
# an empty design of the UP5K's layout (BLANK_BITSTREAM_TOOL): flash refuses anything that is not an
# iCE40 UP5K bitstream.
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

grep -q "^then: deltactl host load --port $work/tty --weights $weights" "$work/out" || fail "no load hint: $(cat "$work/out")"

# Another gateware: identify.mem's build id (payload bytes 4..7, words 2 and 3) changed.
python3 -c 'import sys
lines = open(sys.argv[1]).read().splitlines()
words = [i for i, l in enumerate(lines) if l and not l.startswith("//")]
lines[words[2]] = "%04x" % (int(lines[words[2]], 16) ^ 0x0ff0)
open(sys.argv[1], "w").write("\n".join(lines) + "\n")' "$work/bits/identify.mem"
status=0
PATH="$work/bin:$PATH" "$deltactl" flash --config "$work/deltactl.conf" --wait 2 >"$work/out2" 2>&1 || status=$?
[[ $status -eq 2 ]] || fail "flash of another gateware without --force: exit $status: $(cat "$work/out2")"
grep -q "is not this deltactl's" "$work/out2" || fail "$(cat "$work/out2")"
start_board "$weights"
status=0
PATH="$work/bin:$PATH" "$deltactl" flash --force --config "$work/deltactl.conf" --wait 2 >"$work/out3" 2>&1 || status=$?
[[ $status -eq 1 ]] || fail "flash --force of another gateware: exit $status: $(cat "$work/out3")"
grep -q "the board's gateware build id differs from the bitstream's" "$work/out3" || fail "$(cat "$work/out3")"
echo "PASS: flash ran the programmer once and verified the board's gateware; another gateware is refused, or fails"
