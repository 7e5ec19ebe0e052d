#!/usr/bin/env bash
# CTest Gateware.TheBitstreamsInputsAreTheSameWhicheverWeightsTheBuildWasConfiguredWith: the
# `bitstream` target's yosys reads the tanh tables and identify.mem from the build's mem directory
# (what `deltactl quantise --weights DELTA_NETWORK_WEIGHTS` writes there, the network_mem target),
# and no other file of it.
# For two W.json (different models) quantised into the same folder, in turn: the three files are
# byte-identical, identify.mem holds the gateware build id (the SHA-256 of rtl/**/*.sv, the same
# for both; weights CRC 0), and the design yosys elaborates from the bitstream's sources and top
# with MemDir = that folder (every $readmemh done, the words in the design) is byte-identical; it
# still elaborates, the same, with every file but the three taken away (yosys fails on a missing
# file). So nothing of the model reaches synthesis, and synthesis, placement and routing (seeded)
# make the same bitstream. Controls: without identify.mem yosys fails at this step; a tanh entry
# changed changes the elaborated design.
# Usage: bitstream_inputs_without_model.sh SOURCE_DIR BUILD_DIR DELTACTL TOP W1.json W2.json SOURCE.sv...
set -euo pipefail
src=$1 build=$2 deltactl=$3 top=$4 first=$5 second=$6
shift 6
sources=("$@")
fail() { echo "FAIL: $*" >&2; exit 1; }
read_by_synthesis=(tanh_table.mem tanh_slope.mem identify.mem)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mem=$work/mem

# shellcheck source=../../scripts/ice40_synth.sh
source "$src/scripts/ice40_synth.sh"
includes=""
for source in "${sources[@]}"; do
  dir="-I$(dirname "$(realpath "$source")")"
  [[ " $includes " == *" $dir "* ]] || includes+=" $dir"
done
# The fpga flow's reading of the sources and its chparam (scripts/fpga_flow.sh), then elaboration
# only: hierarchy runs every $readmemh of the parameterised modules.
elaborate() {  # elaborate OUT.il LOG: the design with MemDir = $mem
  local script=""
  for source in "${sources[@]}"; do script+="read_verilog -defer -sv$includes $(realpath "$source"); "; done
  script+="chparam -set MemDir \"$mem\" $top; hierarchy -top $top; write_rtlil $1"
  local params=("MemDir=\"$mem\"")
  FPGA_MOUNTS=("$work")
  fpga_mount_inputs
  fpga_yosys -q -l "$2" -p "$script" >/dev/null 2>&1
}
quantise() {  # quantise W.json NAME: into $mem (emptied first), a copy kept in $work/NAME
  rm -rf "$mem" && mkdir "$mem"
  "$deltactl" quantise --weights "$1" --out-dir "$mem" >"$work/$2.out" 2>&1 || { cat "$work/$2.out" >&2; fail "quantise $1"; }
  cp -r "$mem" "$work/$2"
  sed -n 's/.*weights CRC-32 \([0-9a-f]\{8\}\).*/\1/p' "$work/$2.out"
}

crc1=$(quantise "$first" first)
elaborate "$work/first.il" "$work/first.log" || { tail -3 "$work/first.log" >&2; fail "yosys ($fpga_tools) on $first's folder"; }
crc2=$(quantise "$second" second)
elaborate "$work/second.il" "$work/second.log" || { tail -3 "$work/second.log" >&2; fail "yosys on $second's folder"; }
echo "models: $first (CRC $crc1), $second (CRC $crc2); yosys: $fpga_tools"
[[ -n $crc1 && -n $crc2 && $crc1 != "$crc2" ]] || fail "the two W.json are not two models (CRC '$crc1', '$crc2')"

differing=0
for file in "$work"/first/*; do
  name=$(basename "$file")
  if cmp -s "$file" "$work/second/$name"; then verdict=same; else verdict=differs; differing=$((differing + 1)); fi
  echo "  $name: $verdict"
done
((differing > 0)) || fail "quantise wrote the same files for both models"
for name in "${read_by_synthesis[@]}"; do
  cmp -s "$work/first/$name" "$work/second/$name" || fail "$name depends on the model: it reaches the bitstream"
done

# The build id: identify.mem's (both), the build's (cmake/GatewareId.cmake), the sources' hash.
id_of() { sed -n 's/.*gateware build id \([0-9a-f]\{8\}\), weights CRC-32 \([0-9a-f]\{8\}\).*/\1 \2/p' "$1"; }
read -r id1 crc_in1 <<<"$(id_of "$work/first/identify.mem")"
read -r id2 crc_in2 <<<"$(id_of "$work/second/identify.mem")"
built=$(sed -n 's/.*kGatewareBuildId = 0x\([0-9a-f]\{8\}\)u;.*/\1/p' "$build/generated/include/delta/gateware.hpp")
hashed=$(cd "$src" && find rtl -name '*.sv' -type f | LC_ALL=C sort | xargs cat | sha256sum | cut -c1-8)
echo "gateware build id: identify.mem $id1 / $id2, the build's $built, sha256 of rtl/**/*.sv $hashed;" \
  "identify.mem's weights CRC $crc_in1 / $crc_in2"
[[ -n $id1 && $id1 == "$id2" && $id1 == "$built" && $id1 == "$hashed" ]] || fail "the gateware build id differs"
[[ $crc_in1 == 00000000 && $crc_in2 == 00000000 ]] || fail "identify.mem carries a model's CRC"
if [[ -d $build/rtl/network/mem ]]; then  # the build's own mem folder (network_mem), when built
  for name in "${read_by_synthesis[@]}"; do
    [[ ! -f $build/rtl/network/mem/$name ]] || cmp -s "$work/first/$name" "$build/rtl/network/mem/$name" ||
      fail "the build's $name differs from quantise's"
  done
fi

cmp -s "$work/first.il" "$work/second.il" || fail "the elaborated design differs between the two models"
for file in "$mem"/*; do
  [[ " ${read_by_synthesis[*]} " == *" $(basename "$file") "* ]] || rm "$file"
done
elaborate "$work/three.il" "$work/three.log" ||
  { tail -3 "$work/three.log" >&2; fail "yosys reads more than ${read_by_synthesis[*]} from the mem folder"; }
cmp -s "$work/first.il" "$work/three.il" || fail "the design elaborated from the three files alone differs"
echo "elaborated $top: $(wc -c <"$work/first.il") bytes of RTLIL, byte-identical for both models and from the three files alone"

# Controls: the reads happen at this step, and the design holds the words they read.
mv "$mem/identify.mem" "$work/identify.mem"
if elaborate "$work/control.il" "$work/control.log"; then fail "control: yosys elaborated without identify.mem"; fi
grep -q "identify.mem" "$work/control.log" || { tail -3 "$work/control.log" >&2; fail "control: yosys failed, not on identify.mem"; }
mv "$work/identify.mem" "$mem/identify.mem"
# The table's last word with its last hex digit changed (0 <-> 1, else 0).
awk '/^[0-9a-f]+$/ { last = NR } { lines[NR] = $0 } END {
  for (i = 1; i <= NR; i++) { if (i == last) sub(/.$/, lines[i] ~ /0$/ ? "1" : "0", lines[i]); print lines[i] } }' \
  "$work/first/tanh_table.mem" >"$mem/tanh_table.mem"
cmp -s "$mem/tanh_table.mem" "$work/first/tanh_table.mem" && fail "control: the tanh table was not changed"
elaborate "$work/changed.il" "$work/changed.log" || fail "control: yosys on a changed tanh table"
cmp -s "$work/first.il" "$work/changed.il" && fail "control: a changed tanh entry left the elaborated design the same"
echo "controls: without identify.mem yosys fails; one tanh entry changed changes the design"
echo PASS
