#!/usr/bin/env bash
# `deltactl doctor` against `deltactl virtual-board` on a pseudo-terminal (CTest
# Deploy.DoctorVirtualBoard, full build only): every check printed with a verdict, the board
# identifies with the configured weights and this build's gateware (ok), the pty has no latency
# timer and says so (skip: not an FTDI device), a 1 s wake-latency probe graded in LinuxCNC's bands.
# Usage: scripts/deploy/doctor_virtual_board.sh DELTACTL WEIGHTS
set -euo pipefail
deltactl=${1:?usage: doctor_virtual_board.sh DELTACTL WEIGHTS}
weights=${2:?usage: doctor_virtual_board.sh DELTACTL WEIGHTS}
fail() { echo "FAIL: $*" >&2; exit 1; }
work=$(mktemp -d)
board_pid=""
cleanup() {
  if [[ -n "$board_pid" ]]; then kill "$board_pid" 2>/dev/null || true; wait "$board_pid" 2>/dev/null || true; fi
  rm -rf "$work"
}
trap cleanup EXIT
mkfifo "$work/ready"
"$deltactl" virtual-board --link "$work/tty" --weights "$weights" >"$work/ready" 2>"$work/board.err" &
board_pid=$!
read -r -t 60 ready <"$work/ready" || fail "virtual board not ready: $(cat "$work/board.err")"
[[ "$ready" == *"$work/tty"* ]] || fail "ready line does not name the link: $ready"
cat "$work/ready" >/dev/null &  # keep draining the board's stdout
printf '[board]\nport = %s\n[network]\nweights = %s\n' "$work/tty" "$weights" >"$work/deltactl.conf"
status=0
"$deltactl" doctor --config "$work/deltactl.conf" --latency-seconds 1 >"$work/table" 2>"$work/err" || status=$?
cat "$work/table"
[[ $status -le 1 ]] || fail "doctor exit $status: $(cat "$work/err")"
for check in config "board device" "latency timer" ModemManager "RT priority" memlock kernel "wake latency" \
             "board identify" service; do
  grep -Eq "^$check +(ok|warn|FAIL|skip) " "$work/table" || fail "no verdict for '$check'"
done
grep -Eq '^board identify +ok .*= '"$weights" "$work/table" || fail "the virtual board did not identify with $weights"
grep -Eq '^board device +ok ' "$work/table" || fail "the pty is not present and accessible"
grep -Eq '^latency timer +skip .*not an FTDI device' "$work/table" || fail "latency timer of a pty"
grep -Eq '^wake latency +(ok|warn|FAIL) +1000 wake-ups at 1 kHz.*(very good|good|acceptable|poor|not acceptable)' \
  "$work/table" || fail "wake latency not graded"
echo "PASS: doctor against the virtual board (exit $status)"
