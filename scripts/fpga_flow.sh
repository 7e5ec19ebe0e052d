#!/usr/bin/env bash
# iCE40 UP5K flow: yosys synth_ice40 -> nextpnr-ice40 --up5k -> icepack, with timing and resource reports.
#
# Usage: scripts/fpga_flow.sh --top MODULE --pcf FILE.pcf --freq MHZ --out DIR [--seed N]
#                             [--tries K] [--place FILE.place] [--param NAME=VALUE]... SOURCE.sv...
#   --freq is the target of every clock the .pcf gives no `set_frequency` for.
#   --tries K: place and route with seeds N, N+1, .. N+K-1 until every clock meets its target
#     (default 1: seed N only); synthesis runs once.
#   --place FILE: fixed BELs for some cells of the netlist (scripts/place_cells.py: "TYPE PREFIX BEL..."
#     lines), set before place and route; a line that no longer matches the design stops the flow.
#   --param sets a top-level parameter (string values are given with their quotes: MemDir='"/abs"').
# The tools (yosys 0.55 / nextpnr-ice40 0.8 from npm when installed, else Debian's; DELTA_FPGA_TOOLS
# chooses) and the synthesis command: scripts/ice40_synth.sh.
# Writes in DIR: TOP.json (netlist), TOP.asc, TOP.bin (bitstream), yosys.log, nextpnr.log,
#   timing.txt (post-route Fmax of each clock against its target, and the seed; exit code 1 when
#   timing fails) and resources.txt (logic cells, DSPs, block RAMs, I/O, PLLs used out of the
#   UP5K's).
# nextpnr prints "Max frequency" once after placement and once after routing: the second is the
# post-route figure, the only one that counts.
set -euo pipefail

usage() { awk 'NR == 1 { next } /^#/ { sub(/^# ?/, ""); print; next } { exit }' "$0"; }
top="" pcf="" freq="" out="" place="" seed=1 tries=1 params=() sources=()
while (($#)); do
  case "$1" in
    --top) top=$2; shift 2 ;;
    --pcf) pcf=$2; shift 2 ;;
    --freq) freq=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --seed) seed=$2; shift 2 ;;
    --tries) tries=$2; shift 2 ;;
    --place) place=$2; shift 2 ;;
    --param) params+=("$2"); shift 2 ;;
    -h|--help) usage; exit 0 ;;
    -*) echo "fpga_flow: unknown option $1" >&2; usage >&2; exit 2 ;;
    *) sources+=("$1"); shift ;;
  esac
done
if [[ -z $top || -z $pcf || -z $freq || -z $out || ${#sources[@]} -eq 0 ]]; then
  echo "fpga_flow: need --top, --pcf, --freq, --out and at least one source" >&2; usage >&2; exit 2
fi
for file in "$pcf" ${place:+"$place"} "${sources[@]}"; do
  [[ -f $file ]] || { echo "fpga_flow: error: $file: no such file" >&2; exit 2; }
done
[[ $seed =~ ^[0-9]+$ && $tries =~ ^[1-9][0-9]*$ ]] ||
  { echo "fpga_flow: --seed and --tries take positive integers" >&2; exit 2; }
mkdir -p "$out"

# -defer elaborates only after chparam, so $readmemh sees the final paths.
chparams=""
for param in "${params[@]}"; do chparams+="chparam -set ${param%%=*} ${param#*=} $top; "; done
# Every source's directory is an include directory of every source (rtl/board includes the
# network's readmemh_load.svh).
includes=""
for source in "${sources[@]}"; do
  dir="-I$(dirname "$(realpath "$source")")"
  [[ " $includes " == *" $dir "* ]] || includes+=" $dir"
done
read_sources=""
for source in "${sources[@]}"; do read_sources+="read_verilog -defer -sv$includes $(realpath "$source"); "; done
# shellcheck source=ice40_synth.sh
source "$(dirname "$0")/ice40_synth.sh"
# The folders a YoWASP tool sees: the output, the .pcf's, the sources' and those a parameter names.
FPGA_MOUNTS=("$(realpath "$out")" "$(dirname "$(realpath "$pcf")")")
fpga_mount_inputs
echo "fpga_flow: yosys ($fpga_tools) $ice40_synth ($top)" >&2
fpga_yosys -q -l "$out/yosys.log" -p "$read_sources $chparams $ice40_synth -top $top -json $out/$top.json" >/dev/null
if [[ -n $place ]]; then
  echo "fpga_flow: fixed places from $(basename "$place")" >&2
  python3 "$(dirname "$0")/place_cells.py" "$place" "$out/$top.json" "$top" 2>"$out/place.log" ||
    { cat "$out/place.log" >&2; exit 1; }
fi

# Place and route with one seed; writes timing.txt and sets timing_ok.
place_and_route() {
  local seed=$1
  echo "fpga_flow: nextpnr-ice40 ($fpga_tools) --up5k, seed $seed (clocks without a pcf target: $freq MHz)" >&2
  fpga_nextpnr --up5k --package sg48 --pcf "$pcf" --json "$out/$top.json" --asc "$out/$top.asc" \
    --freq "$freq" --seed "$seed" --timing-allow-fail --log "$out/nextpnr.log" -q >/dev/null 2>&1 ||
    { echo "fpga_flow: nextpnr failed, see $out/nextpnr.log" >&2; tail -5 "$out/nextpnr.log" >&2; exit 1; }

  # Post-route Fmax: the second "Max frequency for clock" line of each clock.
  local fmax_lines clock_count post_route line achieved verdict
  fmax_lines=$(grep "Max frequency for clock" "$out/nextpnr.log" || true)
  clock_count=$(printf '%s\n' "$fmax_lines" | sed -n 's/.*clock *'"'"'\([^'"'"']*\)'"'"'.*/\1/p' | sort -u | wc -l)
  post_route=$(printf '%s\n' "$fmax_lines" | tail -n "$clock_count")
  {
    echo "# Timing of $top on the iCE40 UP5K (nextpnr-ice40, seed $seed); targets from $(basename "$pcf"), else $freq MHz"
    echo "# post-route (the second nextpnr figure of each clock):"
    printf '%s\n' "$post_route" | sed 's/^Info: *//; s/^Warning: *//'
  } >"$out/timing.txt"
  timing_ok=1
  while read -r line; do
    [[ -z $line ]] && continue
    achieved=$(sed -n 's/.*: *\([0-9.]*\) MHz (\(PASS\|FAIL\).*/\1/p' <<<"$line")
    verdict=$(sed -n 's/.*(\(PASS\|FAIL\) at.*/\1/p' <<<"$line")
    [[ $verdict == PASS ]] || timing_ok=0
    echo "fmax_mhz $achieved ($verdict)" >>"$out/timing.txt"
  done <<<"$post_route"
}

for ((try = 0; try < tries; try++)); do
  place_and_route $((seed + try))
  ((timing_ok == 1)) && break
  ((try + 1 < tries)) && echo "fpga_flow: seed $((seed + try)) misses timing:" \
    "$(grep -c "^fmax_mhz.*FAIL" "$out/timing.txt") clock(s); next seed" >&2
done

echo "fpga_flow: icepack" >&2
icepack "$out/$top.asc" "$out/$top.bin"

# Resources: nextpnr's device utilisation table.
{
  echo "# Resources of $top on the iCE40 UP5K (used / available)"
  sed -n '/Device utilisation:/,/^Info: *$/p' "$out/nextpnr.log" | sed 's/^Info: *//' | grep -E '^[[:space:]]*(ICESTORM_(LC|RAM|DSP|PLL|SPRAM)|SB_IO|SB_GB):' || true
} >"$out/resources.txt"
cat "$out/timing.txt" "$out/resources.txt"
if ((timing_ok == 0)); then
  echo "fpga_flow: timing FAILED (seeds $seed..$((seed + tries - 1))), see $out/timing.txt" >&2
  exit 1
fi
echo "fpga_flow: bitstream $out/$top.bin" >&2
