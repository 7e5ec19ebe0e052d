#!/usr/bin/env bash
# CTest Gateware.PlaceCellsPinsTheNamedCellsOrStopsWithTheLineAndLeavesTheNetlist: scripts/place_cells.py
# (fpga_flow.sh --place) on a small netlist of the shape yosys writes: a good line sets nextpnr's BEL
# attribute on exactly the cells of its type and prefix, in name order, and touches no other cell;
# a line matching more or fewer cells than its BELs, a BEL given twice, a line without BELs and a
# missing top each exit 1 with one line naming the file and line (or the netlist), the netlist
# byte-identical. Then rtl/board/icebreaker.place itself: every line well formed, no BEL twice.
# Usage: place_cells_checks.sh SOURCE_DIR
set -euo pipefail
src=$1
tool=$src/scripts/place_cells.py
fail() { echo "FAIL: $*" >&2; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cat >"$work/netlist.json" <<'J'
{"modules": {"top": {"cells": {
  "u_a.p_q_SB_MAC16_O_1": {"type": "SB_MAC16", "attributes": {}},
  "u_a.p_q_SB_MAC16_O": {"type": "SB_MAC16", "attributes": {"src": "a.sv:1"}},
  "u_a.p_q_SB_DFF_Q": {"type": "SB_DFF", "attributes": {}},
  "u_b.q_SB_MAC16_O": {"type": "SB_MAC16", "attributes": {}}}}}}
J
cp "$work/netlist.json" "$work/original.json"

printf '# comment\nSB_MAC16 u_a.p_q X0/Y5/mac16_0 X0/Y10/mac16_0  # trailing\n' >"$work/good.place"
python3 "$tool" "$work/good.place" "$work/netlist.json" top 2>"$work/err" || fail "good file refused: $(cat "$work/err")"
python3 - "$work/netlist.json" <<'P' || fail "the BELs are not where the line puts them"
import json, sys
cells = json.load(open(sys.argv[1]))["modules"]["top"]["cells"]
bel = {n: c["attributes"].get("BEL") for n, c in cells.items()}
assert bel["u_a.p_q_SB_MAC16_O"] == "X0/Y5/mac16_0", bel
assert bel["u_a.p_q_SB_MAC16_O_1"] == "X0/Y10/mac16_0", bel
assert bel["u_a.p_q_SB_DFF_Q"] is None and bel["u_b.q_SB_MAC16_O"] is None, bel
assert cells["u_a.p_q_SB_MAC16_O"]["attributes"]["src"] == "a.sv:1"
P

refused() {  # refused NAME CONTENT EXPECTED-TEXT [TOP]
  local name=$1 content=$2 expected=$3 top=${4:-top}
  cp "$work/original.json" "$work/netlist.json"
  printf "$content" >"$work/$name.place"
  if python3 "$tool" "$work/$name.place" "$work/netlist.json" "$top" 2>"$work/err"; then
    fail "$name: accepted"
  fi
  [[ $(wc -l <"$work/err") -eq 1 ]] || fail "$name: not one line: $(cat "$work/err")"
  grep -qF "$expected" "$work/err" || fail "$name: '$(cat "$work/err")' lacks '$expected'"
  cmp -s "$work/netlist.json" "$work/original.json" || fail "$name: the netlist changed"
}
refused too_few 'SB_MAC16 u_a.p_q X0/Y5/mac16_0\n' "too_few.place:1: SB_MAC16 'u_a.p_q' matches 2 cells"
refused too_many '\nSB_MAC16 u_a.p_q X0/Y5/mac16_0 X0/Y10/mac16_0 X0/Y15/mac16_0\n' "too_many.place:2:"
refused none 'SB_MAC16 u_c X0/Y5/mac16_0\n' "matches 0 cells"
refused twice 'SB_MAC16 u_a.p_q X0/Y5/mac16_0 X0/Y10/mac16_0\nSB_MAC16 u_b X0/Y5/mac16_0\n' \
  "twice.place:2: BEL X0/Y5/mac16_0 given twice"
refused short 'SB_MAC16 u_a.p_q\n' "short.place:1: expected TYPE PREFIX BEL"
refused top 'SB_MAC16 u_a.p_q X0/Y5/mac16_0 X0/Y10/mac16_0\n' "no module other" other

# The tree's own file: well formed, each BEL once.
awk '{ sub(/#.*/, "") } NF { if (NF < 3) { print FILENAME ":" NR ": expected TYPE PREFIX BEL..."; bad = 1 }
       for (i = 3; i <= NF; i++) { if (seen[$i]++) { print FILENAME ":" NR ": " $i " twice"; bad = 1 } } }
     END { exit bad }' "$src/rtl/board/icebreaker.place" || fail "rtl/board/icebreaker.place"
echo "place_cells: 1 good file and 6 refusals as specified; icebreaker.place well formed"
