#!/usr/bin/env bash
# One gateware for every model, measured on models trained on robots the project never saw. For
# each of three virtual robots (effects and seeds printed): a calibration drag on the model board
# (host home, host record while the stage drags the plate, the stage on its own clock), merge,
# train (docs/lab_loop.md, sections 1-4); then onto an RTL virtual board and a model board, each
# started with no model: host load (timed; under 10 s), host status --json (weights_crc: the CRC
# quantise prints), host home and host run experiment1, which must complete; the RTL and model
# boards' recordings of the same run in board time (deltactl cosim: the host's streaming loop with
# every deadline in board time, the model loaded over the link at start) cmp-identical; and
# deltactl ik --backend rtl = --backend fixed (raw codes) on every pose of the merged drag and of a
# held-out sweep. Exit 1 on any failure. About 5 minutes a robot on 2 cores at load 2 (the RTL
# board runs at 0.1-0.4 x real time); run by hand, not in the test suite.
# Usage: model_as_data.sh SOURCE_DIR DELTACTL SCRATCH [RUN_SECONDS]
#   RUN_SECONDS: seconds of experiment 1 run on each board (default 10; 0: all 50 s of it)
set -euo pipefail
source_dir=$1 deltactl=$(realpath "$2") scratch=$3 run_s=${4:-10}
[[ $run_s =~ ^[0-9]+([.][0-9]+)?$ ]] || { echo "model_as_data: RUN_SECONDS must be a number: $run_s" >&2; exit 2; }
duration=()
if [[ $run_s != 0 ]]; then duration=(--duration "$run_s"); fi
rm -rf "$scratch" && mkdir -p "$scratch"
scratch=$(realpath "$scratch")
board_pid=""
trap 'if [[ -n $board_pid ]]; then kill "$board_pid" 2>/dev/null || true; wait "$board_pid" 2>/dev/null || true; fi' EXIT
failures=0
fail() { echo "FAIL: $*"; failures=$((failures + 1)); }
die() { echo "FAIL: $*"; exit 1; }
now() { date +%s.%N; }
seconds_since() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.2f", b - a }'; }

# start_board DIR ARGS...: a virtual board on DIR/tty, ready when it prints its line.
start_board() {
  local dir=$1 ready
  shift
  rm -f "$dir/ready" "$dir/tty" && mkfifo "$dir/ready"
  "$deltactl" virtual-board --link "$dir/tty" "$@" >"$dir/ready" 2>>"$dir/board.err" &
  board_pid=$!
  exec {lines}<"$dir/ready"
  while read -r -t 120 -u "$lines" ready; do  # the stage's line comes first
    echo "  $ready"
    [[ $ready == *"ready on $dir/tty"* ]] && break
  done
  [[ ${ready:-} == *"ready on $dir/tty"* ]] || die "virtual board not ready: $(tail -3 "$dir/board.err")"
  cat <&"$lines" >/dev/null &
  exec {lines}<&-
}
stop_board() {
  kill "$board_pid" 2>/dev/null || true
  wait "$board_pid" || true
  board_pid=""
}
rows() { grep -v '^#' "$1" | tail -n +2 | wc -l; }  # data rows of a CSV (no comments, no header)
raw_codes() { grep -v '^#' "$1" | tail -n +2 | cut -d, -f4-6; }  # alpha*_raw of an ik output

# The robots: effects files of the vocabulary (docs/contracts.md), none of them in the repository;
# each with its power-up pose, the stage's clock (offset s, ppm), rate and seed, and a training seed.
robots=(
  '{"joint_offset": [0.31, -0.52, 0.18], "lower_arm_length": [0.00021, -0.00026, 0.00011], "frame_misalignment": {"rx": 0.12, "ry": -0.27, "rz": 2.2, "tx": 0.0002, "ty": -0.00012, "tz": 0.00009}, "backlash": [0.1, 0.06, 0.15]}'
  '{"joint_offset": [-0.36, 0.14, 0.47], "upper_arm_length": [-0.00018, 0.00011, 0.00029], "radius_offset": [0.00022, -0.00031, 0.0001], "encoder_scale": [0.002, -0.004, 0.003], "transmission_error": {"amplitude_deg": [0.02, 0.03, 0.015], "period_deg": [8.0, 6.0, 15.0], "phase_rad": [0.7, 2.5, 4.1]}, "backlash": [0.05, 0.12, 0.0]}'
  '{"joint_offset": [0.09, 0.41, -0.28], "lower_arm_length": [-0.00019, 0.00028, 0.0], "chain_angle": [0.21, -0.16, 0.3], "frame_misalignment": {"rx": -0.21, "ry": 0.3, "rz": -3.8, "tx": -0.00018, "ty": 0.00022, "tz": -0.00017}, "encoder_scale": [-0.004, 0.001, 0.003], "backlash": [0.14, 0.0, 0.09]}'
)
start_angles=('24.1,33.7,27.9' '36.2,26.4,31.5' '28.8,22.6,35.1')
stage_clocks=('18.4,-95' '6.9,160' '33.1,45')
stage_rates=(500 250 800)
seeds=(101 202 303)

summary=()
for r in 0 1 2; do
  n=$((r + 1)) dir=$scratch/robot$n
  mkdir -p "$dir"
  echo "${robots[$r]}" >"$dir/effects.json"
  echo "== robot $n: effects ${robots[$r]}"
  echo "   power-up angles ${start_angles[$r]} deg; stage clock ${stage_clocks[$r]} (s, ppm) at ${stage_rates[$r]} Hz," \
    "stage seed ${seeds[$r]}; train --seed ${seeds[$r]}; sweep seed $((seeds[r] + 1))"

  # The lab loop's drag, merge and training (docs/lab_loop.md, sections 1-4).
  start=$(now)
  start_board "$dir" --fidelity model --free-run --effects "$dir/effects.json" --start-angles "${start_angles[$r]}" \
    --stage drag:calibration --stage-after-home 0 --stage-log "$dir/drag_stage.csv" --stage-clock "${stage_clocks[$r]}" \
    --stage-rate "${stage_rates[$r]}" --stage-seed "${seeds[$r]}"
  "$deltactl" host home --quiet --port "$dir/tty" --weights "$source_dir/weights/paper_like_deployed.json" \
    --link-timeout-ms 3000 >"$dir/home_drag.out" 2>&1 || die "robot $n: host home before the drag: $(tail -2 "$dir/home_drag.out")"
  "$deltactl" host record --port "$dir/tty" --out "$dir/drag_run.csv" --duration 300 --link-timeout-ms 3000 \
    >"$dir/record.out" 2>&1 || die "robot $n: host record: $(tail -2 "$dir/record.out")"
  stop_board
  "$deltactl" merge --run "$dir/drag_run.csv" --stage "$dir/drag_stage.csv" --out "$dir/drag.csv" \
    --report "$dir/drag_merge.json" >"$dir/merge.out" 2>&1 || die "robot $n: merge: $(tail -2 "$dir/merge.out")"
  "$deltactl" train --data "$dir/drag.csv" --out "$dir/W.json" --seed "${seeds[$r]}" >"$dir/train.out" 2>"$dir/train.err" ||
    die "robot $n: train: $(tail -2 "$dir/train.err")"
  mkdir -p "$dir/mem"
  crc=$("$deltactl" quantise --weights "$dir/W.json" --out-dir "$dir/mem" 2>&1 |
    sed -n 's/.*weights CRC-32 \([0-9a-f]\{8\}\).*/\1/p')
  [[ -n $crc ]] || die "robot $n: quantise printed no CRC"
  echo "   drag 300 s, merged $(rows "$dir/drag.csv") rows, trained: model $crc ($(seconds_since "$start") s)"

  # The model onto each board, started with no model.
  declare -A load_s=() load_wall=()
  for fidelity in rtl model; do
    start_board "$dir" --fidelity "$fidelity" --no-model --effects "$dir/effects.json"
    status=$("$deltactl" host status --json --port "$dir/tty")
    [[ $status == *'"model":"none"'* ]] || fail "robot $n, $fidelity: a board started with --no-model has a model: $status"
    start=$(now)
    load=$("$deltactl" host load --json --port "$dir/tty" --weights "$dir/W.json") ||
      { fail "robot $n, $fidelity: host load"; stop_board; continue; }
    wall=$(seconds_since "$start")
    load_wall[$fidelity]=$wall
    load_s[$fidelity]=$(sed -n 's/.*"seconds":\([0-9.e+-]*\).*/\1/p' <<<"$load")
    echo "   $fidelity: host load $wall s wall (the load itself ${load_s[$fidelity]} s): $load"
    awk -v w="$wall" 'BEGIN { exit !(w < 10) }' || fail "robot $n, $fidelity: host load took $wall s (10 s allowed)"
    status=$("$deltactl" host status --json --port "$dir/tty")
    [[ $status == *"\"weights_crc\":\"$crc\""* && $status == *'"model":"loaded"'* ]] ||
      fail "robot $n, $fidelity: host status --json does not report model $crc: $status"
    "$deltactl" host home --quiet --port "$dir/tty" --weights "$dir/W.json" --link-timeout-ms 2000 >"$dir/home_$fidelity.out" 2>&1 ||
      fail "robot $n, $fidelity: host home: $(tail -2 "$dir/home_$fidelity.out")"
    start=$(now)
    if "$deltactl" host run --port "$dir/tty" --weights "$dir/W.json" --trajectory experiment1 "${duration[@]}" \
      --record "$dir/run_$fidelity.csv" --link-timeout-ms 2000 >"$dir/run_$fidelity.out" 2>&1; then
      echo "   $fidelity: host home, host run experiment1 complete ($(seconds_since "$start") s wall):" \
        "$(grep '^stream:' "$dir/run_$fidelity.out")"
    else
      fail "robot $n, $fidelity: host run: $(tail -3 "$dir/run_$fidelity.out")"
    fi
    stop_board
  done
  if cmp -s "$dir/run_rtl.csv" "$dir/run_model.csv"; then pty_runs="identical"; else pty_runs="not identical"; fi
  echo "   host run's recordings over the ptys: $pty_runs ($(rows "$dir/run_rtl.csv") and" \
    "$(rows "$dir/run_model.csv") rows; the host in wall time, below)"
  # Over the ptys the host keeps wall time and the boards do not run at one speed (the RTL board
  # at 0.1-0.4 x real time, the model board at real time): the board times of its commands differ,
  # so those two recordings are not compared byte for byte. The same run in board time:
  for fidelity in rtl model; do
    "$deltactl" cosim --fidelity "$fidelity" --weights "$dir/W.json" --effects "$dir/effects.json" \
      --trajectory experiment1 --duration "$run_s" --out "$dir/cosim_$fidelity.csv" >"$dir/cosim_$fidelity.out" 2>&1 ||
      fail "robot $n: cosim --fidelity $fidelity: $(tail -2 "$dir/cosim_$fidelity.out")"
  done
  if cmp "$dir/cosim_rtl.csv" "$dir/cosim_model.csv"; then
    recordings="cmp-identical ($(rows "$dir/cosim_rtl.csv") rows, $(wc -c <"$dir/cosim_rtl.csv") bytes)"
  else
    recordings="DIFFER"
    fail "robot $n: the RTL and model boards' recordings differ"
  fi
  echo "   recordings (cosim, experiment1 ${run_s} s, RTL vs model board): $recordings"

  # ik: rtl = fixed on every pose, the merged drag (in time order) and a held-out sweep.
  "$deltactl" simulate --experiment sweep --effects "$dir/effects.json" --seed $((seeds[r] + 1)) \
    --out "$dir/sweep.csv" >/dev/null 2>&1 || die "robot $n: simulate sweep"
  ik="equal"
  for data in drag sweep; do
    for backend in rtl fixed; do
      "$deltactl" ik --weights "$dir/W.json" --backend "$backend" --in "$dir/$data.csv" --out "$dir/ik_${data}_$backend.csv" \
        >/dev/null 2>"$dir/ik_${data}_$backend.err" || die "robot $n: ik --backend $backend on $data: $(tail -1 "$dir/ik_${data}_$backend.err")"
    done
    poses=$(raw_codes "$dir/ik_${data}_rtl.csv" | wc -l)
    [[ $poses == $(rows "$dir/$data.csv") ]] || fail "robot $n: ik rtl on $data: $poses rows"
    if cmp -s <(raw_codes "$dir/ik_${data}_rtl.csv") <(raw_codes "$dir/ik_${data}_fixed.csv"); then
      echo "   ik --backend rtl = --backend fixed on all $poses poses of the $data"
      ik+=" ${data} ${poses}"
    else
      fail "robot $n: ik rtl and fixed differ on the $data"
      ik="DIFFER"
    fi
  done
  summary+=("robot $n, model $crc: host load rtl ${load_wall[rtl]:-?} s (load ${load_s[rtl]:-?} s), model ${load_wall[model]:-?} s (${load_s[model]:-?} s); recordings $recordings; ik $ik")
  unset load_s load_wall
done

echo "== model_as_data: experiment1 ${run_s} s a board"
printf '%s\n' "${summary[@]}"
if ((failures > 0)); then
  echo "FAIL: $failures failure(s)"
  exit 1
fi
echo PASS
