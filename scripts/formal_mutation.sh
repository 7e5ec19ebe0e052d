#!/usr/bin/env bash
# Mutation score of the formal properties (docs/formal.md): each mutant is a copy of rtl/ with one
# operator changed in the synthesised logic (never in an `ifdef FORMAL` block) of a checked module;
# scripts/formal.sh proves that module's job on it. A mutant is killed when a property fails or a
# cover becomes unreachable; a mutant yosys cannot read, or whose only failure is a cover not reached
# in the time, is not counted.
#
#   scripts/formal_mutation.sh [--out DIR] [--per-module N] [--timeout S] [--seed K] [--jobs N] [--module NAME]...
#
# Writes DIR/score.txt (one line per mutant: module, line, change, killed by / survived) and
# prints the score. N mutants per module (default 6), drawn with the printed seed, and for link_rx
# four hand-made ones in the ring's addressing.
set -euo pipefail

here=$(cd "$(dirname "$0")/.." && pwd)
out=$here/build/formal/mutation
per_module=6
timeout=10
seed=1
jobs=2
chosen=
while [ $# -gt 0 ]; do
  case $1 in
    --out) out=$2; shift 2 ;;
    --per-module) per_module=$2; shift 2 ;;
    --timeout) timeout=$2; shift 2 ;;
    --seed) seed=$2; shift 2 ;;
    --jobs) jobs=$2; shift 2 ;;
    --module) chosen="$chosen $2"; shift 2 ;;
    -h|--help) awk 'NR == 1 { next } /^#/ { sub(/^# ?/, ""); print; next } { exit }' "$0"; exit 0 ;;
    *) echo "formal_mutation.sh: unknown argument '$1' (try --help)" >&2; exit 2 ;;
  esac
done
mkdir -p "$out"
work=$(mktemp -d "${TMPDIR:-/tmp}/mutation.XXXXXX")
trap 'rm -rf "$work"' EXIT
echo "formal_mutation: seed $seed, $per_module mutants per module, PDR timeout $timeout s"

# module file -> the proof job that checks it [-> the lines mutated: board_core's commands, its own
# causes, the jog and the drive state; the rest of board_core (telemetry, LEDs, counters) is checked
# by simulation, not here]
modules="joint/joint_safety.sv:joint_safety joint/joint_pwm.sv:joint_pwm board/setpoint_buffer.sv:setpoint_buffer
board/link_rx.sv:link_rx board/link_crc16.sv:link_rx board/uart_rx.sv:uart_rx board/board_safety_inputs.sv:board_safety_inputs
board/board_core.sv:board_core:193-333"
if [ -n "$chosen" ]; then
  picked=
  for m in $modules; do
    for c in $chosen; do [ "$(basename "${m%%:*}" .sv)" != "$c" ] || picked="$picked $m"; done
  done
  modules=$picked
fi

# The mutants: one operator per line of synthesised logic (python3: the line list, the operators).
python3 - "$here/rtl" "$per_module" "$seed" "$modules" >"$work/mutants" <<'EOF'
import random, re, sys
rtl, per_module, seed, modules = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4].split()
swaps = [(' == ', ' != '), (' != ', ' == '), (' <= ', ' < '), (' < ', ' <= '), (' >= ', ' > '), (' > ', ' >= '),
         (' && ', ' || '), (' || ', ' && '), ("1'b1", "1'b0"), ("1'b0", "1'b1"), (' + ', ' - '), (' - ', ' + '),
         ('(!', '('), (' !', ' '), ("6'd4", "6'd5"), ("6'd3", "6'd2"), ("4'd0", "4'd1")]
rng = random.Random(seed)
for entry in modules:
    path, job, *span = entry.split(':')
    lines = open(f'{rtl}/{path}').read().split('\n')
    first, last = (int(x) for x in span[0].split('-')) if span else (1, len(lines))
    candidates, formal = [], 0
    for number, line in enumerate(lines):
        if not first <= number + 1 <= last:
            continue
        code = line.split('//')[0]
        words = code.split()
        if words[:2] == ['`ifdef', 'FORMAL']: formal = 1
        elif formal and words[:1] in (['`ifdef'], ['`ifndef']): formal += 1  # nested, inside the block
        elif formal and words[:1] == ['`endif']:
            formal -= 1
            continue
        if formal or not code.strip() or code.strip().startswith(('module', 'parameter', 'input', 'output', 'localparam', 'logic')):
            continue
        for old, new in swaps:
            start = code.find(old)
            if start < 0:
                continue
            prefix = code[:start]
            if old.endswith('!') and code[start + len(old):].startswith('='):
                continue  # part of !=, not a negation
            if old == ' <= ' and prefix.count('(') == prefix.count(')'):
                continue  # a non-blocking assignment, not a comparison
            candidates.append((number, old, new, start))
    rng.shuffle(candidates)
    for number, old, new, start in candidates[:per_module]:
        print('\x1f'.join([path, job, str(number + 1), old, new, str(start)]))
    # Hand-made, always run: the link ring's addressing, which no operator swap reaches (a pointer
    # that skips a slot, a write or read one slot off, the data changed on its way into the RAM).
    handmade = {'board/link_rx.sv': [("write_q <= write_q + 1'b1;", " + 1'b1", " + 2'd2"),
                                     ("assign ring_write_addr = write_q;", "write_q;", "write_q + 1'b1;"),
                                     ("assign ring_read_addr  = read_q;", "read_q;", "read_q + 1'b1;"),
                                     ("assign ring_write_data = rx_data_i;", "rx_data_i;", "rx_data_i ^ 8'h01;")],
                # the safety inputs: a wrong polarity, one synchroniser stage, a filter that counts 2,
                # a latch that clears itself, a clear that wins over a latching sample, no refusal
                'board/board_safety_inputs.sv': [("assign raw = {drive_fault_i, estop_open_i};", "{drive_fault_i", "~{drive_fault_i"),
                                                 ("sync_q <= meta_q;", "meta_q;", "raw;"),
                                                 ("assign latch[i] = sample_i && sync_q[i] && history == '1;", "history == '1", "history[0]"),
                                                 ("else if (clear_i) cause_q[i] <= 1'b0;", "if (clear_i)", "if (!sample_i)"),
                                                 ("if (latch[i]) cause_q[i] <= 1'b1;", "latch[i])", "latch[i] && !clear_i)"),
                                                 ("stopping_o = stopping_o || history_q[HistoryBits * i];", " || history_q[HistoryBits * i]", "")],
                # a clear that ignores the safety inputs still at stop
                'board/board_core.sv': [("assign fault_active        = joint_fault_active || inputs_stopping;", " || inputs_stopping", "")]}
    for line_text, old, new in handmade.get(path, []):
        number = next(n for n, line in enumerate(lines) if line_text in line)
        print('\x1f'.join([path, job, str(number + 1), old, new, str(lines[number].find(old))]))
EOF

killed=0 survived=0 invalid=0
: >"$out/score.txt"
while IFS=$'\x1f' read -r path job line old new column; do
  rm -rf "$work/rtl" && cp -r "$here/rtl" "$work/rtl"
  python3 - "$work/rtl/$path" "$line" "$column" "$old" "$new" <<'EOF'
import sys
path, line, column, old, new = sys.argv[1], int(sys.argv[2]) - 1, int(sys.argv[3]), sys.argv[4], sys.argv[5]
lines = open(path).read().split('\n')
text = lines[line]
# the operator at its column (the swaps carry their surrounding spaces)
at = text.find(old, column)
lines[line] = text[:at] + new + text[at + len(old):]
open(path, 'w').write('\n'.join(lines))
EOF
  set +e
  result=$("$here/scripts/formal.sh" --rtl "$work/rtl" --only "$job" --jobs "$jobs" --timeout "$timeout" --quiet --stop-at-failure 2>&1)
  rc=$?
  set -e
  what="$path:$line '$old' -> '$new'"
  if [ $rc = 3 ]; then
    invalid=$((invalid + 1)); verdict="not valid SystemVerilog for yosys (not counted)"
  elif [ $rc = 0 ]; then
    survived=$((survived + 1)); verdict="SURVIVED"
  elif grep -q "FAILED (not reached within" <<<"$result" && ! grep -q "FAILED (\(counterexample\|unreachable\)" <<<"$result"; then
    # a cover the bounded search did not reach in its time: no verdict (raise --timeout)
    invalid=$((invalid + 1)); verdict="undecided: a cover not reached within the time (not counted)"
  else
    killed=$((killed + 1))
    verdict="killed by $(grep -m1 -o '^\(assert\|cover\) *[a-z_]* *[A-Za-z_.]*' <<<"$result" | awk '{print $1, $3}')"
  fi
  printf '%-60s %s\n' "$what" "$verdict" | tee -a "$out/score.txt"
done <"$work/mutants"
total=$((killed + survived))
[ $total -gt 0 ] || { echo "formal_mutation: no mutants" >&2; exit 1; }
printf 'formal_mutation: %d of %d mutants killed (%d %%), %d survived, %d not counted (unreadable or undecided)\n' \
  "$killed" "$total" "$((100 * killed / total))" "$survived" "$invalid" | tee -a "$out/score.txt"
