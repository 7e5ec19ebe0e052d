#!/usr/bin/env bash
# Formal proofs of the board's safety properties (docs/formal.md): the immediate assertions,
# assumptions and covers in the RTL's `ifdef FORMAL` blocks, proved per module with Debian's
# yosys 0.23, yosys-abc (PDR, unbounded) and yosys-smtbmc with z3 (counterexamples).
#
#   scripts/formal.sh [--out DIR] [--jobs N] [--timeout S] [--only JOB] [--rtl DIR] [--quiet]
#                     [--stop-at-failure]
#
# One line per property: its verdict (proven: PDR, unbounded; passed to depth N: bounded, when PDR
# ran out of time; FAILED) and the time. Every cover must be reached (a counterexample to its
# negation) or the run fails: a property whose cover is unreachable would pass vacuously.
# On a failure: DIR/<job>.<property>.vcd (waveform) and DIR/<job>.<property>_tb.v (testbench) from
# yosys-smtbmc, and exit 1 (exit 3 when yosys cannot read the RTL). --rtl points at another copy
# of rtl/ (the mutation run's mutants); --stop-at-failure ends at the first failure.
set -euo pipefail

here=$(cd "$(dirname "$0")/.." && pwd)
rtl=$here/rtl
out=$here/build/formal
jobs=2
timeout=60        # CPU seconds of PDR per property before falling back to bounded model checking
bmc_depth=40      # depth of that fallback, and of the first search for a cover
cover_depth=120   # depth of the search for a cover on the cover configuration (then PDR)
only=
quiet=0
stop=0
while [ $# -gt 0 ]; do
  case $1 in
    --out) out=$2; shift 2 ;;
    --jobs) jobs=$2; shift 2 ;;
    --timeout) timeout=$2; shift 2 ;;
    --only) only=$2; shift 2 ;;
    --rtl) rtl=$2; shift 2 ;;
    --quiet) quiet=1; shift ;;
    --stop-at-failure) stop=1; shift ;;
    -h|--help) awk 'NR == 1 { next } /^#/ { sub(/^# ?/, ""); print; next } { exit }' "$0"; exit 0 ;;
    *) echo "formal.sh: unknown argument '$1' (try --help)" >&2; exit 2 ;;
  esac
done
rtl=$(cd "$rtl" && pwd)  # absolute: build_job runs yosys in the model's directory
for tool in yosys yosys-abc yosys-smtbmc z3; do
  command -v $tool >/dev/null || { echo "formal.sh: $tool not found: run scripts/setup.sh" >&2; exit 2; }
done
mkdir -p "$out"
work=$(mktemp -d "${TMPDIR:-/tmp}/formal.XXXXXX")
[ -n "${FORMAL_KEEP:-}" ] || trap 'rm -rf "$work"' EXIT; [ -z "${FORMAL_KEEP:-}" ] || echo "formal.sh: work directory $work" >&2

pkg="$rtl/board/delta_board_pkg.sv $rtl/joint/delta_joint_pkg.sv"

# ---- the proof jobs: name, top module, sources, yosys commands after reading them ----------------
# Submodules' assumptions become assertions in a composition (their environment is checked); their
# covers are dropped there (each is reached in the submodule's own job).
# Blackboxed submodules (yosys `blackbox`) drive their outputs freely: a sound over-approximation.
# job NAME TOP SOURCES [BLACKBOX_SOURCES] [TRUSTED]: BLACKBOX_SOURCES are read for their ports
# only; TRUSTED submodules keep their assumptions (each is proved by another job, named there).
job_names=()
declare -A job_top job_src job_lib job_trusted job_cover job_setup job_rom
job() { job_names+=("$1"); job_top[$1]=$2; job_src[$1]=$(echo $3); job_lib[$1]=$(echo ${4:-}); job_trusted[$1]=${5:-}; }
# cover_config JOB YOSYS_COMMANDS: the covers too deep for the shipped constants (a 2500-period
# watchdog, a 256-entry buffer, a byte per 208 clocks, a play every 10 x 2325 clocks) are searched on a second model of the
# same RTL with one time-scale constant made small (chparam, or a FORMAL-only define read before
# the sources); the assertions are always proved on the shipped constants. docs/formal.md argues
# why a cover reached there shows that the assertion it belongs to is not vacuous.
cover_config() { job_cover[$1]=$2; }
# job_depth JOB N: the depth of the bounded fallback for this job's assertions, where 40 clocks
# see too little (link_rx: a byte every 208 clocks; 450 clocks hold two). Kept in a file, not an
# array like the others: check() reads it in the xargs workers, which inherit no arrays.
job_depth() { echo "$2" >"$work/$1.depth"; }
# cover_search_depth JOB N: the depth of the first bounded search for the job's covers, where 40
# clocks see too little and no time-scale constant shortens it (joint_controller: a run is 1072
# clocks; the covers' cones hold its schedule only, not its datapath).
cover_search_depth() { echo "$2" >"$work/$1.cover_depth"; }
# keep_roms JOB: the read-only memories yosys makes of constant case tables (proc_rom: the
# controllers' microprogram) stay in the model with their contents; only memories with a write
# port (block RAM) are cut out.
keep_roms() { job_rom[$1]=1; }
# job_config JOB YOSYS_COMMANDS: the job's own model (shipped and cover configurations) is read
# with these (a FORMAL-only define or a chparam), e.g. to pick the environment its properties need.
job_config() { job_setup[$1]=$2; }

job joint_safety joint_safety "$rtl/joint/joint_safety.sv"
job joint_pwm joint_pwm "$rtl/joint/joint_pwm.sv"
# The board's safety inputs: synchronisers, the filter, the latches.
job board_safety_inputs board_safety_inputs "$rtl/board/board_safety_inputs.sv"
job setpoint_buffer setpoint_buffer "$rtl/board/setpoint_buffer.sv"
job link_rx link_rx "$rtl/board/link_crc16.sv $rtl/board/link_rx.sv"
# The model loader (the model flag, the drives-on refusal, the serial CRC against CRC-32).
job model_loader model_loader "$rtl/board/model_loader.sv"
# The UART receiver twice: under an 8N1 transmitter, and under any line at all.
job uart_rx uart_rx "$rtl/board/uart_rx.sv"
job uart_rx_any_line uart_rx "$rtl/board/uart_rx.sv"
job_config uart_rx_any_line "define FORMAL_UART_RX_ANY_LINE 1"
# The board's command logic with joint_axes (fault latch, PWM, encoders), the setpoint buffer, the
# model loader and the safety inputs; link_rx (job link_rx: its delivery, as setpoint_buffer's and
# model_loader's assumptions state it, the stall included) and the controllers' current clamp (job
# joint_controller) trusted.
job board_core board_core "$rtl/network/delta_network_pkg.sv $rtl/board/board_core.sv $rtl/board/setpoint_buffer.sv $rtl/board/model_loader.sv $rtl/board/board_safety_inputs.sv $rtl/joint/joint_axes.sv
    $rtl/joint/joint_safety.sv $rtl/joint/joint_pwm.sv $rtl/joint/quadrature_counter.sv" \
  "$rtl/network/readmemh_table.sv $rtl/network/model_ram.sv $rtl/network/delta_network.sv $rtl/board/network_crossing.sv
    $rtl/board/reference_interpolator.sv $rtl/board/link_tx.sv $rtl/board/uart_tx.sv $rtl/board/uart_rx.sv
    $rtl/board/link_rx.sv $rtl/joint/joint_controller.sv" \
  "setpoint_buffer joint_pwm model_loader"
# What the model board (host/cosim/model_board.cpp) relies on (docs/formal.md): link_tx's payload
# RAM and word index (read with SYNTHESIS defined: readmemh_load.svh's $readmemh, the RAM cut out
# as everywhere), the interpolator's schedule, the controllers' state memory while idle.
job link_tx link_tx "$rtl/board/link_crc16.sv $rtl/board/link_tx.sv"
job_config link_tx "define SYNTHESIS 1"
job reference_interpolator reference_interpolator "$rtl/board/reference_interpolator.sv"
job joint_controller joint_controller "$rtl/joint/joint_state_ram.sv $rtl/joint/joint_controller.sv"
job quadrature_counter quadrature_counter "$rtl/joint/quadrature_counter.sv"
# uart_tx at the board's bit time (delta_board_pkg's LinkClocksPerBit; its default is another).
job uart_tx uart_tx "$rtl/board/uart_tx.sv"
job_config uart_tx "chparam -set ClocksPerBit $(sed -n 's/.*int LinkClocksPerBit[^=]*= *\([0-9]*\);.*/\1/p' "$rtl/board/delta_board_pkg.sv") uart_tx"
# joint_axes with the controllers' datapath a black box (its outputs free) and joint_pwm's current
# clamp trusted, as in board_core.
job joint_axes joint_axes "$rtl/joint/joint_axes.sv $rtl/joint/joint_safety.sv $rtl/joint/joint_pwm.sv
    $rtl/joint/quadrature_counter.sv" "$rtl/joint/joint_controller.sv" "joint_pwm"
cover_config joint_safety "chparam -set WatchdogPeriods 3 joint_safety"
cover_config setpoint_buffer "chparam -set Depth 4 setpoint_buffer"
cover_config link_rx "define FORMAL_LINK_RX_BYTE_GAP 1"
job_depth link_rx 450
keep_roms joint_controller
cover_search_depth joint_controller 1100
cover_config uart_rx "chparam -set ClocksPerBit 4 uart_rx"
cover_config uart_tx "chparam -set ClocksPerBit 4 uart_tx"
cover_config uart_rx_any_line "chparam -set ClocksPerBit 4 uart_rx"
cover_config board_core "chparam -set ClocksPerPeriod 4 board_core; chparam -set ModelCommitFrame 1 board_core"
cover_config model_loader "chparam -set CommitFrameNumber 2 model_loader"
job_depth model_loader 60
cover_search_depth model_loader 200

# ---- build the models: one AIGER per assertion and per cover (negated) ---------------------------
cat >"$work/cover2assert.v" <<'EOF'
module \$cover (A, EN);
  input A, EN;
  \$assert _TECHMAP_REPLACE_ (.A(!A), .EN(EN));
endmodule
EOF
cat >"$work/aig.ys" <<'EOF'
flatten
async2sync
memory_map
opt -full
techmap
opt -fast
dffunmap
setundef -undriven -anyseq
abc -g AND -fast
opt_clean
delete -output
EOF
cat >"$work/smt.ys" <<'EOF'
flatten
async2sync
dffunmap
setundef -undriven -anyseq
opt_clean
EOF

build_job() {  # job [cover] -> $work/<job>[.cover]/{model.il, model.aig, props}
  local j=$1 d=$work/$1 defines= params= lemmas=
  if [ "${2:-}" = lemmas ]; then  # the proven assertions become assumptions (names in $work/<job>.proven)
    d=$work/$1.lemmas
    local name
    while read -r name; do lemmas="$lemmas n:$name"; done <"$work/$1.proven"
    lemmas="chformal -assert2assume $lemmas;"
  fi
  local config mode=${2:-}
  for config in "${job_setup[$j]:-}" "$([ "$mode" != cover ] || echo "${job_cover[$j]}")"; do
    case $config in
      '') ;;
      define\ *) set -- $config; defines="$defines -D$2=$3" ;;
      *) params="$params $config;" ;;
    esac
  done
  [ "$mode" != cover ] || d=$work/$j.cover
  mkdir -p "$d"
  local top=${job_top[$j]}
  local lib=
  local f cut=
  for f in ${job_lib[$j]}; do  # black boxes: the module header (ports) only; their cells removed
    sed -n '/^module /,/^);/p' "$f" >"$d/stub.$(basename "$f")"
    echo endmodule >>"$d/stub.$(basename "$f")"
    lib="$lib read_verilog -lib -sv $d/stub.$(basename "$f");"
    cut="$cut t:*$(sed -n 's/^module \([A-Za-z0-9_]*\).*/\1/p' "$f" | head -1)"
  done
  [ -z "$cut" ] || cut="delete $cut;"
  local memories='t:$mem_v2 t:$mem'
  [ -z "${job_rom[$j]:-}" ] || memories='t:$mem_v2 r:WR_PORTS=0 %d t:$mem'
  # yosys reads in the model's directory: a $readmemh of MemDir "." (link_tx's identify.mem) finds
  # a file there, one zero word (the RAM is cut out: its contents are free anyway).
  echo 0000 >"$d/identify.mem"
  # The trusted modules by name, and as hierarchy names them when an instance sets a parameter
  # ($paramod\NAME\PARAM=... or $paramod$HASH\NAME): a plain name alone misses those.
  local keep="$top"
  for m in ${job_trusted[$j]}; do keep+=" $m \$paramod*$m*"; done
  if ! (cd "$d" && yosys -q -l "$d/read.log" -p "read_verilog -formal -sv -I$rtl/network $defines $pkg ${job_src[$j]}; $lib $params hierarchy -top $top;
        prep -top $top; select -set keep $keep; chformal -assume -assume2assert @keep %n; chformal -cover -remove $top %n;
        flatten; $cut $lemmas memory -nomap; delete $memories; setundef -undriven -anyseq; opt_clean;
        write_rtlil $d/model.il;
        tee -q -o $d/asserts select -list t:\$assert; tee -q -o $d/covers select -list t:\$cover" >/dev/null 2>&1); then
    echo "formal.sh: yosys could not read job $j (log: $d/read.log):" >&2
    grep -m3 ERROR "$d/read.log" >&2 || true
    return 1
  fi
  # Lower once (covers turned into assertions of their negation: a counterexample reaches them),
  # turn every assertion into an output (its failure), write one AIGER; each check takes the cone
  # of its output.
  yosys -q -l "$d/lower.log" -p "read_rtlil $d/model.il; techmap -map $work/cover2assert.v t:\$cover;
      script $work/aig.ys; write_rtlil $d/lowered.il" >/dev/null 2>&1 ||
    { echo "formal.sh: yosys failed on job $j (log: $d/lower.log)" >&2; return 1; }
  python3 "$here/scripts/formal_outputs.py" "$d/lowered.il" "$d/outputs.il" "$d/outputs" &&
    yosys -q -l "$d/aiger.log" -p "read_rtlil $d/outputs.il; write_aiger -zinit $d/model.aig" >/dev/null 2>&1 ||
    { echo "formal.sh: yosys failed on job $j (log: $d/aiger.log)" >&2; return 1; }
  : >"$d/props"
  local index=0 name
  while read -r name; do
    if grep -qx "[^/]*/$name" "$d/covers"; then echo "cover $name $index"; else echo "assert $name $index"; fi >>"$d/props"
    index=$((index + 1))
  done <"$d/outputs"
}

# ---- check one property: prints "job kind name verdict seconds" ------------------------------------
# yosys-abc with a budget of CPU seconds (ulimit), not of wall-clock time: a verdict should not
# depend on how busy the machine is. Where the kernel does not enforce CPU limits (some sandboxes)
# a wall-clock limit of FORMAL_WALL_FACTOR (default 4) times the budget stops it as well.
abc_cpu() { (ulimit -t "$1"; timeout $(($1 * ${FORMAL_WALL_FACTOR:-4})) yosys-abc -c "$2" 2>&1) || true; }
export -f abc_cpu
check() {
  local j=$1 kind=$2 name=$3 index=$4 d=$work/$1 config=shipped
  local aig="$d/model.aig; fold; strash; cone -O $index -s; scleanup" t0 t1 log verdict frame
  t0=$(date +%s.%N)
  log=
  # A cover is usually reached in a few frames: bounded search first; a deep one on the job's
  # cover configuration when it has one, else PDR.
  local first_depth=$bmc_depth
  [ ! -f "$work/$j.cover_depth" ] || first_depth=$(cat "$work/$j.cover_depth")
  [ "$kind" != cover ] || log=$(abc_cpu $timeout "read_aiger $aig; bmc3 -F $first_depth")
  if [ "$kind" = cover ] && ! grep -q "asserted in frame" <<<"$log" && [ -f "$work/$j.cover/props" ]; then
    d=$work/$j.cover config=cover
    index=$(awk -v n="$name" '$2 == n {print $3}' "$d/props")
    aig="$d/model.aig; fold; strash; cone -O $index -s; scleanup"
    log=$(abc_cpu $timeout "read_aiger $aig; bmc3 -F $cover_depth")
  fi
  grep -q "asserted in frame" <<<"$log" ||
    log=$(abc_cpu $timeout "read_aiger $aig; scorr; pdr")
  if grep -q "Property proved" <<<"$log"; then
    verdict=proven
  elif frame=$(grep -o "asserted in frame [0-9]*" <<<"$log" | grep -o "[0-9]*$"); then
    verdict="cex@$frame"
  else
    # PDR ran out of time: bounded model checking to the job's depth (bmc_depth, or job_depth's).
    local depth=$bmc_depth
    [ ! -f "$work/${j%.lemmas}.depth" ] || depth=$(cat "$work/${j%.lemmas}.depth")
    log=$(abc_cpu $((timeout * 3)) "read_aiger $aig; bmc3 -F $depth -T $((timeout * 2))")
    if frame=$(grep -o "asserted in frame [0-9]*" <<<"$log" | grep -o "[0-9]*$"); then
      verdict="cex@$frame"
    elif grep -q "No output asserted in $depth frames" <<<"$log"; then
      verdict="depth@$depth"
    else
      verdict="depth@$(grep -o "No output asserted in [0-9]* frames" <<<"$log" | grep -o "[0-9]*" | head -1)"
      [ "$verdict" != "depth@" ] || verdict=unknown
    fi
  fi
  t1=$(date +%s.%N)
  printf '%s %s %s %s %.2f %s\n' "$j" "$kind" "$name" "$verdict" "$(echo "$t1 - $t0" | bc)" "$config"
  # --stop-at-failure: exit status 255 makes xargs stop.
  if [ "$stop" = 1 ] && { { [ $kind = assert ] && [[ $verdict != proven && $verdict != depth@* ]]; } ||
                          { [ $kind = cover ] && [[ $verdict != cex@* ]]; }; }; then exit 255; fi
}
export -f check
export work timeout bmc_depth cover_depth stop

# ---- counterexample: waveform and testbench from yosys-smtbmc ---------------------------------------
counterexample() {
  local j=$1 name=$2 frame=$3 d=$work/$1
  local safe=${name//[^A-Za-z0-9_.]/_}
  yosys -q -p "read_rtlil $d/model.il; chformal -cover -remove; chformal -assert -remove t:\$assert n:$name %d;
      script $work/smt.ys; write_smt2 -wires $d/cex.$safe.smt2" >/dev/null 2>&1 || return 0
  yosys-smtbmc -s z3 -t $((frame + 2)) --dump-vcd "$out/$j.$safe.vcd" --dump-vlogtb "$out/$j.${safe}_tb.v" \
      "$d/cex.$safe.smt2" >"$out/$j.$safe.smtbmc.log" 2>&1 || true
  echo "  counterexample: $out/$j.$safe.vcd, testbench $out/$j.${safe}_tb.v"
}

# Jobs left out of a run without --only (none: docs/formal.md, "Status", says what each gave).
pending=" "
selected=()
for j in "${job_names[@]}"; do
  if { [ -z "$only" ] && [[ $pending != *" $j "* ]]; } || [ "$j" = "$only" ]; then selected+=("$j"); fi
done
[ ${#selected[@]} -gt 0 ] || { echo "formal.sh: no job named '$only'" >&2; exit 2; }

start=$(date +%s.%N)
for j in "${selected[@]}"; do
  build_job "$j" || exit 3
  [ -z "${job_cover[$j]:-}" ] || build_job "$j" cover || exit 3
done
for j in "${selected[@]}"; do
  while read -r kind name index; do echo "$j $kind $name $index"; done <"$work/$j/props"
done | xargs -P "$jobs" -L 1 bash -c 'check "$0" "$1" "$2" "$3"' >"$work/results" 2>/dev/null || true
# An assertion yosys folds to a constant true (it holds by the logic's construction) has no output.
for j in "${selected[@]}"; do
  sed 's|^[^/]*/||' "$work/$j/asserts" | while read -r name; do
    grep -qx "$name" "$work/$j/outputs" || echo "$j assert $name proven 0 construction"
  done
done >>"$work/results"

# Second round: an assertion PDR did not finish is proved again with every assertion proven in
# the first round assumed (sound: those hold in every reachable state of the same model). The
# lemmas among the properties (docs/formal.md) are there for this.
: >"$work/second"
for j in "${selected[@]}"; do
  awk -v j="$j" '$1 == j && $2 == "assert" && $4 == "proven" {print $3}' "$work/results" >"$work/$j.proven"
  awk -v j="$j" '$1 == j && $2 == "assert" && $4 != "proven" && $4 !~ /^cex@/ {print $3}' "$work/results" >"$work/$j.undecided"
  [ -s "$work/$j.undecided" ] && [ -s "$work/$j.proven" ] || continue
  build_job "$j" lemmas || exit 3
  while read -r name; do
    echo "$j.lemmas assert $name $(awk -v n="$name" '$1 == "assert" && $2 == n {print $3}' "$work/$j.lemmas/props")"
  done <"$work/$j.undecided" >>"$work/second"
done
xargs -P "$jobs" -L 1 bash -c 'check "$0" "$1" "$2" "$3"' <"$work/second" >"$work/results2" 2>/dev/null || true
while read -r j kind name verdict seconds config; do
  [ "$verdict" = proven ] || continue
  awk -v j="${j%.lemmas}" -v n="$name" -v v="$verdict" -v s="$seconds" \
    '$1 == j && $3 == n {$4 = v; $5 = $5 + s; $6 = "lemmas"} {print}' "$work/results" >"$work/results.new"
  mv "$work/results.new" "$work/results"
done <"$work/results2"

failed=0 proven=0 bounded=0 reached=0 props=0 covers=0
while read -r j kind name verdict seconds config; do
  line=
  if [ "$kind" = assert ]; then
    props=$((props + 1))
    case $verdict in
      proven) line="proven"; proven=$((proven + 1)); [ "$config" != lemmas ] || line="proven (with the proven lemmas)"
              [ "$config" != construction ] || line="proven (constant: holds by construction)" ;;
      depth@*) line="passed to depth ${verdict#depth@}"; bounded=$((bounded + 1)) ;;
      cex@*) line="FAILED (counterexample in frame ${verdict#cex@})"; failed=$((failed + 1)) ;;
      *) line="FAILED (no verdict)"; failed=$((failed + 1)) ;;
    esac
  else
    covers=$((covers + 1))
    case $verdict in
      cex@*) line="reached in frame ${verdict#cex@}"; reached=$((reached + 1))
             [ "$config" = shipped ] || line="$line with $(awk '{print $1 == "define" ? $2 " = " $3 : $3 " = " $4}' <<<"${job_cover[$j]}")" ;;
      proven) line="FAILED (unreachable: the property it covers is vacuous)"; failed=$((failed + 1)) ;;
      *) line="FAILED (not reached within $bmc_depth frames)"; failed=$((failed + 1)) ;;
    esac
  fi
  if [ $quiet = 0 ] || [[ $line == FAILED* ]]; then
    printf '%-7s %-15s %-58s %-58s %7.2f s\n' "$kind" "$j" "$name" "$line" "$seconds"
  fi
  if [ "$kind" = assert ] && [[ $verdict == cex@* ]] && [ $quiet = 0 ]; then
    counterexample "$j" "$name" "${verdict#cex@}"
  fi
done < <(sort -k1,1 -k2,2 -s "$work/results")
end=$(date +%s.%N)
printf 'formal: %d properties: %d proven (unbounded), %d passed to a depth, %d covers reached of %d; %d failed; %.1f s\n' \
  "$props" "$proven" "$bounded" "$reached" "$covers" "$failed" "$(echo "$end - $start" | bc)"
[ $failed = 0 ]
