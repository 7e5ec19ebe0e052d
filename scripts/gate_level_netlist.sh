#!/usr/bin/env bash
# Synthesises an RTL top for the iCE40 UP5K with yosys (ice40_synth.sh, as the FPGA flow) and
# writes the gate-level netlist (SB_LUT4, SB_CARRY, SB_DFF*, SB_MAC16, SB_RAM40_4K cells, memories
# filled from the .mem files) for simulation with yosys's cells_sim.v.
#
# Usage: scripts/gate_level_netlist.sh --top MODULE --out NETLIST.v [--param NAME=VALUE]... SOURCE.sv...
# Fails when yosys reports a warning that means the netlist differs from the RTL's intent
# (implicitly declared identifiers, out-of-bounds selects, multiple drivers).
set -euo pipefail

top="" out="" params=() sources=()
while (($#)); do
  case "$1" in
    --top) top=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --param) params+=("$2"); shift 2 ;;
    -h|--help) awk 'NR == 1 { next } /^#/ { sub(/^# ?/, ""); print; next } { exit }' "$0"; exit 0 ;;
    -*) echo "gate_level_netlist: unknown option $1" >&2; exit 2 ;;
    *) sources+=("$1"); shift ;;
  esac
done
[[ -n $top && -n $out && ${#sources[@]} -gt 0 ]] || { echo "gate_level_netlist: need --top, --out and sources" >&2; exit 2; }

# Every source's directory is an include directory of every source (rtl/board includes the
# network's readmemh_load.svh).
# yosys reads them from the tree's root by paths relative to it: the names it makes of functions
# hold the path, so a clone in another folder writes the same netlist (and its model is a
# compiler-cache hit).
root=$(cd "$(dirname "$0")/.." && pwd)
out=$(realpath -m "$out")
relative() { realpath -m --relative-to="$root" "$1"; }
includes=""
for source in "${sources[@]}"; do
  dir="-I$(dirname "$(relative "$source")")"
  [[ " $includes " == *" $dir "* ]] || includes+=" $dir"
done
# shellcheck source=ice40_synth.sh
source "$(dirname "$0")/ice40_synth.sh"
# yosys writes into a scratch folder (a YoWASP tool sees only the folders it is given).
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
script=""
for source in "${sources[@]}"; do script+="read_verilog -defer -sv$includes $(relative "$source"); "; done
for param in "${params[@]}"; do script+="chparam -set ${param%%=*} ${param#*=} $top; "; done
script+="$ice40_synth -top $top; write_verilog -noattr $work/netlist.v"
log="$out.yosys.log"
FPGA_MOUNTS=("$work")
fpga_mount_inputs relative
(cd "$root" && fpga_yosys -q -l "$work/yosys.log" -p "$script" >/dev/null 2>&1) ||
  { cp "$work/yosys.log" "$log" 2>/dev/null; tail -5 "$log" >&2; echo "gate_level_netlist: yosys ($fpga_tools) failed, see $log" >&2; exit 1; }
cp "$work/yosys.log" "$log"
if grep -E "is implicitly declared|out of bounds|multiple conflicting drivers" "$log" | grep -v "^$" >&2; then
  echo "gate_level_netlist: yosys warnings above change the design; see $log" >&2
  exit 1
fi
mv "$work/netlist.v" "$out"
