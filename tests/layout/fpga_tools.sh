#!/usr/bin/env bash
# The FPGA tools' choice (scripts/ice40_synth.sh) and the YoWASP runner (scripts/yowasp_run.mjs),
# with a stand-in for the npm packages (no synthesis runs): YoWASP when both packages are installed,
# else Debian's tools; an unknown DELTA_FPGA_TOOLS refused in one line (exit 2); a tool run by the
# runner reads and writes the mounted folders at their absolute paths and, with --relative, at
# their paths from its working directory, and nothing it writes elsewhere reaches the disk.
# Usage: fpga_tools.sh SOURCE_DIR.
set -euo pipefail
source_dir=$(cd "$1" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "fpga tools: $*" >&2; exit 1; }

choice() {  # prints fpga_tools, ice40_synth and ice40_cells_sim for the environment given
  env "$@" bash -c "source '$source_dir/scripts/ice40_synth.sh' && echo \"\$fpga_tools|\$ice40_synth|\$ice40_cells_sim\""
}
mkdir -p "$work/npm/@yowasp/yosys/gen" "$work/npm/@yowasp/nextpnr-ice40/gen"
# The stand-in yosys: copies /sub/in.txt (the relative mount) to /sub/copy.txt, to ABS/copy.txt
# (args[0], the absolute mount) and to /elsewhere.txt (no mount); exit code 3 when asked.
cat >"$work/npm/@yowasp/yosys/gen/bundle.js" <<'JS'
export async function runYosys(args, files) {
  const text = files.sub["in.txt"];
  files.sub["copy.txt"] = text;
  let node = files;
  for (const part of args[0].split("/").filter(Boolean)) node = node[part];
  node["copy.txt"] = text;
  files["elsewhere.txt"] = text;
  if (args[1] === "fail") { const error = new Error("exit"); error.code = 3; error.files = files; throw error; }
  return files;
}
JS

result=$(choice DELTA_YOWASP="$work/npm" DELTA_FPGA_TOOLS=)
[[ $result == "debian|scratchpad -set abc9.nomfs 1; synth_ice40 -dsp -abc9|/usr/share/yosys/ice40/cells_sim.v" ]] ||
  fail "one package installed: expected Debian's tools, got '$result'"
echo 'export async function runNextpnrIce40() {}' >"$work/npm/@yowasp/nextpnr-ice40/gen/bundle.js"
result=$(choice DELTA_YOWASP="$work/npm" DELTA_FPGA_TOOLS=)
[[ $result == "yowasp|synth_ice40 -dsp -abc2 -dffe_min_ce_use 4|$work/npm/@yowasp/yosys/gen/share/ice40/cells_sim.v" ]] ||
  fail "both packages installed: expected YoWASP's tools, got '$result'"
result=$(choice DELTA_YOWASP="$work/npm" DELTA_FPGA_TOOLS=debian)
[[ $result == debian\|* ]] || fail "DELTA_FPGA_TOOLS=debian: got '$result'"
if message=$(choice DELTA_FPGA_TOOLS=vivado 2>&1); then fail "DELTA_FPGA_TOOLS=vivado accepted"; else status=$?; fi
[[ $status == 2 && $(wc -l <<<"$message") == 1 && $message == *"DELTA_FPGA_TOOLS=vivado"* ]] ||
  fail "DELTA_FPGA_TOOLS=vivado: expected one line and exit 2, got $status: $message"

mkdir -p "$work/cwd/sub" "$work/abs"
echo "the design" >"$work/cwd/sub/in.txt"
(cd "$work/cwd" && DELTA_YOWASP="$work/npm" node "$source_dir/scripts/yowasp_run.mjs" yosys \
  --relative sub --mount "$work/abs" -- "$work/abs")
[[ $(cat "$work/cwd/sub/copy.txt") == "the design" ]] || fail "the relative mount's file was not written back"
[[ $(cat "$work/abs/copy.txt") == "the design" ]] || fail "the absolute mount's file was not written back"
[[ ! -e $work/cwd/elsewhere.txt && ! -e /elsewhere.txt ]] || fail "a file outside the mounts reached the disk"
rm "$work/abs/copy.txt"
status=0
(cd "$work/cwd" && DELTA_YOWASP="$work/npm" node "$source_dir/scripts/yowasp_run.mjs" yosys \
  --mount "$work/abs" --relative sub -- "$work/abs" fail) || status=$?
[[ $status == 3 && -f $work/abs/copy.txt ]] || fail "a failing tool: expected its exit code 3 and its files, got $status"
if message=$(cd "$work/cwd" && node "$source_dir/scripts/yowasp_run.mjs" yosys --relative ../up -- 2>&1); then
  fail "--relative ../up accepted"
else status=$?; fi
[[ $status == 2 && $message == *"--relative ../up"* ]] || fail "--relative ../up: expected exit 2 naming it, got $status: $message"
echo "fpga tools: the choice and the YoWASP runner's mounts behave"
