# The FPGA tools and the yosys synthesis command of the iCE40 UP5K, one home for the bitstream
# (fpga_flow.sh), the gate-level models the tests run (gate_level_netlist.sh) and the logic by
# module (area_by_module.sh): the netlist tested is the one flashed. Sourced, not run.
#
# The tools: yosys 0.55 and nextpnr-ice40 0.8 from npm (YoWASP, WebAssembly under Node.js;
# scripts/setup.sh installs them into $DELTA_YOWASP, default ~/.cache/delta-yowasp/node_modules)
# when they are installed, else Debian's yosys 0.23 and nextpnr-ice40 0.4. DELTA_FPGA_TOOLS=debian
# or =yowasp chooses (yowasp fails when they are not installed).
# Sets: fpga_tools (yowasp|debian), ice40_synth (the synthesis command of those tools),
# ice40_cells_sim (their iCE40 cell models, for simulating the netlist) and the functions
# fpga_yosys / fpga_nextpnr (run the tool; FPGA_MOUNTS, an array, names the directories a YoWASP
# tool sees: an absolute path at that path, a relative one at that path from its working directory).

fpga_scripts_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
fpga_yowasp_root=${DELTA_YOWASP:-$HOME/.cache/delta-yowasp/node_modules}
case ${DELTA_FPGA_TOOLS:-} in
  "") if [[ -f $fpga_yowasp_root/@yowasp/yosys/gen/bundle.js && -f $fpga_yowasp_root/@yowasp/nextpnr-ice40/gen/bundle.js ]] &&
         command -v node >/dev/null; then
        fpga_tools=yowasp
      else
        fpga_tools=debian
      fi ;;
  yowasp | debian) fpga_tools=$DELTA_FPGA_TOOLS ;;
  *) echo "ice40_synth: DELTA_FPGA_TOOLS=$DELTA_FPGA_TOOLS: expected yowasp or debian" >&2; exit 2 ;;
esac

if [[ $fpga_tools == yowasp ]]; then
  # yosys 0.55: -abc9 is synth_ice40's default mapping (ABC's timing-driven mapping with the carry
  # and LUT delays), its &mfs step included. -abc2 (a second ABC pass) and -dffe_min_ce_use 4 (a
  # clock enable shared by fewer than 4 flip-flops goes into their LUTs, so they pack with logic)
  # take 53 logic cells off the board (4975 -> 4922 packed) and do not slow either clock.
  ice40_synth="synth_ice40 -dsp -abc2 -dffe_min_ce_use 4"
  ice40_cells_sim=$fpga_yowasp_root/@yowasp/yosys/gen/share/ice40/cells_sim.v
else
  # yosys 0.23: -abc9 (about 45 fewer logic cells than the default mapping), without its final
  # &mfs step (Debian's ABC aborts in it on this design: Gia_ManInsertMfs assertion).
  ice40_synth="scratchpad -set abc9.nomfs 1; synth_ice40 -dsp -abc9"
  ice40_cells_sim=/usr/share/yosys/ice40/cells_sim.v
fi

FPGA_MOUNTS=()
# fpga_mount_inputs [relative]: adds to FPGA_MOUNTS the folders of the caller's sources (array
# `sources`) and those its parameters name (array `params`, NAME=VALUE: the .mem files' MemDir);
# with `relative`, the sources' folders as the caller's function `relative` names them.
fpga_mount_inputs() {
  local source dir value param
  for source in "${sources[@]}"; do
    if [[ ${1:-} == relative ]]; then dir=$(dirname "$(relative "$source")"); else dir=$(dirname "$(realpath "$source")"); fi
    [[ " ${FPGA_MOUNTS[*]} " == *" $dir "* ]] || FPGA_MOUNTS+=("$dir")
  done
  for param in "${params[@]}"; do
    value=${param#*=}; value=${value//\"/}
    [[ -d $value ]] && FPGA_MOUNTS+=("$(realpath "$value")")
  done
  return 0
}
fpga_yowasp_args() {  # yowasp_run.mjs's options for FPGA_MOUNTS
  local dir
  for dir in "${FPGA_MOUNTS[@]}"; do
    if [[ $dir == /* ]]; then printf '%s\n' --mount "$dir"; else printf '%s\n' --relative "$dir"; fi
  done
  printf '%s\n' --
}
fpga_yosys() {
  if [[ $fpga_tools == yowasp ]]; then
    local args
    mapfile -t args < <(fpga_yowasp_args)
    node "$fpga_scripts_dir/yowasp_run.mjs" yosys "${args[@]}" "$@"
  else
    yosys "$@"
  fi
}
fpga_nextpnr() {
  if [[ $fpga_tools == yowasp ]]; then
    local args
    mapfile -t args < <(fpga_yowasp_args)
    node "$fpga_scripts_dir/yowasp_run.mjs" nextpnr-ice40 "${args[@]}" "$@"
  else
    nextpnr-ice40 "$@"
  fi
}
