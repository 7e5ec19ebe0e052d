#!/usr/bin/env bash
# Where the UP5K's logic goes, module by module: the bitstream's synthesis (scripts/ice40_synth.sh,
# with its tools) with the hierarchy kept (-noflatten), then per module its LUT4s, carries,
# flip-flops, block RAMs and DSPs, times its instances. Kept apart, modules cannot share logic across their ports, so the
# sum is above the flat design's logic cells (resources.txt of the bitstream): read the shares,
# not the sum.
#
# Usage: scripts/area_by_module.sh --top MODULE --out FILE [--param NAME=VALUE]... SOURCE.sv...
#   (cmake --build build --target area_by_module writes build/rtl/board/fpga/area_by_module.txt)
set -euo pipefail
usage() { awk 'NR == 1 { next } /^#/ { sub(/^# ?/, ""); print; next } { exit }' "$0"; }
top="" out="" params=() sources=()
while (($#)); do
  case "$1" in
    --top) top=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --param) params+=("$2"); shift 2 ;;
    -h|--help) usage; exit 0 ;;
    -*) echo "area_by_module: unknown option $1" >&2; usage >&2; exit 2 ;;
    *) sources+=("$1"); shift ;;
  esac
done
if [[ -z $top || -z $out || ${#sources[@]} -eq 0 ]]; then
  echo "area_by_module: need --top, --out and at least one source" >&2; usage >&2; exit 2
fi
for file in "${sources[@]}"; do
  [[ -f $file ]] || { echo "area_by_module: error: $file: no such file" >&2; exit 2; }
done
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
includes=""
for source in "${sources[@]}"; do
  dir="-I$(dirname "$(realpath "$source")")"
  [[ " $includes " == *" $dir "* ]] || includes+=" $dir"
done
# shellcheck source=ice40_synth.sh
source "$(dirname "$0")/ice40_synth.sh"
{
  for source in "${sources[@]}"; do echo "read_verilog -defer -sv$includes $(realpath "$source")"; done
  for param in "${params[@]}"; do echo "chparam -set ${param%%=*} ${param#*=} $top"; done
  echo "$ice40_synth -noflatten -top $top"
  echo "tee -q -o $work/stat.txt stat"
} > "$work/script.ys"
FPGA_MOUNTS=("$work")
fpga_mount_inputs
echo "area_by_module: yosys ($fpga_tools) $ice40_synth -noflatten ($top), a few minutes" >&2
fpga_yosys -q -l "$work/yosys.log" -s "$work/script.ys" > /dev/null 2>&1 ||
  { echo "area_by_module: yosys failed:" >&2; tail -5 "$work/yosys.log" >&2; exit 1; }
python3 - "$work/stat.txt" "$top" > "$out.tmp" <<'PY'
import re, sys
# yosys 0.23's `stat -json` is not valid JSON on this design: the text report is read.
modules, name = {}, None
for line in open(sys.argv[1]):
    head = re.match(r"^=== (.*) ===$", line.strip())
    if head:
        name = head.group(1)
        modules[name] = {} if name != "design hierarchy" else None
        continue
    cell = re.match(r"^\s+(\S+)\s+(\d+)$", line)
    if cell and name and modules.get(name) is not None and not line.strip().startswith("Number"):
        modules[name][cell.group(1)] = int(cell.group(2))
modules = {k: v for k, v in modules.items() if v is not None}
def plain(name):  # $paramod$HASH\name or $paramod\name\P=V: the module's own name
    return name.split("\\")[1] if name.startswith("$paramod") else name.lstrip("\\")
count = {}  # instances of each module under the top
def walk(name, times):
    count[name] = count.get(name, 0) + times
    for cell, n in modules[name].items():
        if cell in modules: walk(cell, times * n)
walk(next(m for m in modules if plain(m) == sys.argv[2]), 1)
merged = {}
for name, times in count.items():
    c = modules[name]
    ff = sum(n for t, n in c.items() if t.startswith("SB_DFF"))
    row = merged.setdefault(plain(name), [plain(name), 0, 0, 0, 0, 0, 0])
    for k, v in enumerate((times, c.get("SB_LUT4", 0), c.get("SB_CARRY", 0), ff, c.get("SB_RAM40_4K", 0),
                           c.get("SB_MAC16", 0)), start=1):
        row[k] += v if k == 1 else times * v
rows = sorted(merged.values(), key=lambda r: -r[2])
total = [sum(r[k] for r in rows) for k in range(1, 7)]
print("# LUT4s, carries, flip-flops, block RAMs and DSPs per module (instances summed), hierarchy kept")
print("%-24s %5s %6s %6s %6s %5s %5s %6s" % ("module", "inst", "LUT4", "carry", "FF", "EBR", "DSP", "LUT4 %"))
for r in rows:
    print("%-24s %5d %6d %6d %6d %5d %5d %5.1f%%" % (r[0], r[1], r[2], r[3], r[4], r[5], r[6], 100.0 * r[2] / total[1]))
print("%-24s %5s %6d %6d %6d %5d %5d" % ("(sum)", "", total[1], total[2], total[3], total[4], total[5]))
PY
mv "$out.tmp" "$out"
cat "$out"
