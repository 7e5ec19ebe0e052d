#!/usr/bin/env bash
# The "Closed-loop runs" table of docs/lab_loop.md, run again: for each robot and path, the model
# virtual board kept to real time with the robot's effects, its deployed model and a stage that
# follows the plate (`--stage follow`, the table's clock and rate), `host home`, `host run
# --trajectory PATH.csv`, `merge` (the found clock against the stage's true one, the merged plate
# against the board's truth recording at the same board times, rows matched by the millisecond as
# StageDrag.* does), `diagnose` with the run as FIT and the robot's merged sweep drag held out; on
# path A also `diagnose` of the run's readings with the truth's plate in place of the stage's ("the
# true plate" rows). One table row per run, in the doc's shape, on stdout and in
# WORK/closed_loop_runs.md.
#
# Usage: scripts/closed_loop_runs.sh [OPTIONS] REPO DELTACTL WORK
#   REPO      the checkout (its docs/lab_loop.md: the robots' effects are checked against it)
#   DELTACTL  the deltactl binary (e.g. REPO/build/bin/deltactl)
#   WORK      a folder for everything (created; each run's folder WORK/robotN/P is emptied first)
# Options:
#   --robots LIST       robots, of 1 and 2 (default 1,2): the doc's robot 1 (play, scales, lower arms,
#                       a 3.1 deg frame) and robot 2 (radius offsets, chain angles, transmission error)
#   --paths LIST        paths, of A and B (default A,B)
#   --effects N=FILE    robot N's effects JSON (default: the doc's, written to WORK/robotN/effects.json)
#   --sweep N=FILE      robot N's merged 620 s sweep drag (DATA.csv), held out by every diagnose
#   --weights N=FILE    robot N's deployed W.json, trained on its merged --train-on drag
#                       Without --sweep or --weights the script makes them as the doc says (section 1's
#                       drags with the robot's clocks, section 2's merge, section 4's train) in
#                       WORK/robotN/prep/: model board free-running, 620 s of drag:sweep and 1340 s of
#                       drag:validation (a few minutes and about 0.8 GB of files per robot)
#   --train-on DRAG     validation (the doc's table) or calibration (900 s): the drag the deployed
#                       model is trained on
#   --true-plate LIST   paths whose runs are also diagnosed with the truth's plate (default A, as the
#                       doc; none: no such rows)
#   --seconds S         cut every path to S s of trajectory time (a smoke test; env CLOSED_LOOP_SECONDS)
#   --drag-seconds S,T  the prepared drags' lengths (default 620,1340 or 620,900; shorter: a smoke test of
#                       the preparation only, their W.json may not cover the paths)
#   --prepare-only      make the missing sweeps and weights, run nothing in closed loop
#   --train-threads N   `train --threads` (default 0: all cores)
#   -h, --help          this text
# Example (the doc's table, both robots prepared here; about 35 min on 2 cores):
#   scripts/closed_loop_runs.sh $PWD $PWD/build/bin/deltactl /tmp/closed_loop
# Time: each run is its path in real time (300 s for A, 240 s for B) plus homing, the approach and
# the ramps (2-3 s), merge (a few s) and one diagnose per FIT (30-60 s each): about 25 min for the
# table's 6 rows, plus the preparation. The closed-loop runs need a quiet machine (the board is
# kept to real time; a host starved for 200 ms loses the link, exit 4).
#
# Paths (generated, 1 kHz, t_s,x_m,y_m,z_m, about the middle of the box every deployed model was
# trained on, W.json's input range): A, WORK/paths/lab_path.csv, 300 s: Lissajous figures of +-3.6 /
# 3.6 / 1.9 mm in x / y / z at 0.013 / 0.017 / 0.011 Hz with faster +-0.5 / 0.5 / 0.3 mm at 0.10 /
# 0.23 / 0.16 Hz (slow: the joints below 1.5 deg/s); B, WORK/paths/path_b.csv, 240 s: +-3.2 / 3.0 /
# 1.6 mm at 0.07 / 0.11 / 0.05 Hz with +-0.3 mm at 0.53 / 0.91 / 0.67 Hz (up to about 5 deg/s).
# Stages: the doc's clocks and rates, seeds 61-64.
# Exit: 0 when every run went through, 1 when one failed (the others still run), 2 on bad usage.
set -euo pipefail

usage() { sed -n '/^# Usage:/,/^# Exit:/p' "$0" | sed 's/^# \{0,1\}//'; }
die() { echo "closed_loop_runs: $*" >&2; exit 2; }

robots=1,2 paths=A,B true_plate=A seconds=${CLOSED_LOOP_SECONDS:-} drag_seconds=
prepare_only=0 train_threads=0 train_on=validation
declare -A effects_of=() sweep_of=() weights_of=()
positional=()
while [[ $# -gt 0 ]]; do
  case $1 in
    -h|--help) usage; exit 0 ;;
    --robots|--paths|--effects|--sweep|--weights|--true-plate|--seconds|--drag-seconds|--train-threads|--train-on)
      [[ $# -ge 2 ]] || die "$1 needs a value"
      case $1 in
        --robots) robots=$2 ;;
        --paths) paths=$2 ;;
        --true-plate) true_plate=$2 ;;
        --seconds) seconds=$2 ;;
        --drag-seconds) drag_seconds=$2 ;;
        --train-threads) train_threads=$2 ;;
        --train-on) train_on=$2 ;;
        --effects|--sweep|--weights)
          [[ $2 =~ ^([12])=(.+)$ ]] || die "$1 takes N=FILE with N 1 or 2, not '$2'"
          case $1 in
            --effects) effects_of[${BASH_REMATCH[1]}]=${BASH_REMATCH[2]} ;;
            --sweep) sweep_of[${BASH_REMATCH[1]}]=${BASH_REMATCH[2]} ;;
            --weights) weights_of[${BASH_REMATCH[1]}]=${BASH_REMATCH[2]} ;;
          esac ;;
      esac
      shift 2 ;;
    --prepare-only) prepare_only=1; shift ;;
    -*) die "unknown option $1 (--help)" ;;
    *) positional+=("$1"); shift ;;
  esac
done
[[ ${#positional[@]} -eq 3 ]] || die "usage: closed_loop_runs.sh [OPTIONS] REPO DELTACTL WORK (--help)"
repo=${positional[0]} deltactl=${positional[1]} work=${positional[2]}
[[ -f $repo/docs/lab_loop.md ]] || die "$repo/docs/lab_loop.md missing: REPO is not the checkout"
[[ -x $deltactl ]] || die "$deltactl is not an executable deltactl"
[[ $robots =~ ^[12](,[12])*$ ]] || die "--robots takes a list of 1 and 2, not '$robots'"
[[ $paths =~ ^[AB](,[AB])*$ ]] || die "--paths takes a list of A and B, not '$paths'"
[[ $true_plate =~ ^(none|[AB](,[AB])*)$ ]] || die "--true-plate takes a list of A and B or none, not '$true_plate'"
[[ -z $seconds || $seconds =~ ^[0-9]+(\.[0-9]+)?$ ]] || die "--seconds takes seconds, not '$seconds'"
[[ -z $drag_seconds || $drag_seconds =~ ^[0-9]+,[0-9]+$ ]] || die "--drag-seconds takes SWEEP,CALIBRATION seconds, not '$drag_seconds'"
[[ $train_on == validation || $train_on == calibration ]] ||
  die "--train-on takes validation or calibration, not '$train_on'"
[[ $train_threads =~ ^[0-9]+$ ]] || die "--train-threads takes a number, not '$train_threads'"
command -v python3 >/dev/null || die "python3 missing (it reads the JSON reports)"
for n in "${!effects_of[@]}" "${!sweep_of[@]}" "${!weights_of[@]}"; do
  for file in "${effects_of[$n]:-}" "${sweep_of[$n]:-}" "${weights_of[$n]:-}"; do
    [[ -z $file || -s $file ]] || die "$file missing or empty"
  done
done
[[ -n $drag_seconds ]] || drag_seconds=620,$([[ $train_on == validation ]] && echo 1340 || echo 900)
IFS=, read -r sweep_seconds train_seconds <<<"$drag_seconds"
IFS=, read -r -a robot_list <<<"$robots"
IFS=, read -r -a path_list <<<"$paths"
deltactl=$(cd "$(dirname "$deltactl")" && pwd)/$(basename "$deltactl")
mkdir -p "$work"
work=$(cd "$work" && pwd)

# The doc's robots (docs/lab_loop.md, "What the merge achieves" and the diagnosis section's
# "Reproduce"), checked against the doc below.
robot_effects_1='{"joint_offset": [-0.42, 0.27, 0.61], "backlash": [0.0, 0.18, 0.1],
 "encoder_scale": [0.0, 0.003, -0.002], "lower_arm_length": [0.0003, -0.0002, 0.0],
 "frame_misalignment": {"rx": 0.12, "ry": -0.2, "rz": 3.1, "tx": 0.0004, "ty": 0.0001, "tz": -0.0003}}'
robot_effects_2='{"joint_offset": [0.35, -0.6, 0.15], "radius_offset": [0.0003, -0.00015, 0.0],
 "chain_angle": [0.3, -0.2, 0.25], "transmission_error": {"amplitude_deg": [0.03, 0.02, 0.015],
 "period_deg": [12.0, 7.0, 20.0], "phase_rad": [0.5, 2.0, 4.0]}, "backlash": [0.12, 0.0, 0.25],
 "frame_misalignment": {"rx": -0.3, "ry": 0.15, "rz": -2.4, "tx": -0.0002, "ty": 0.0003, "tz": 0.0001}}'
# Stages (OFFSET_S,PPM RATE_HZ SEED): the drags of the doc's diagnosis section and the closed-loop runs.
declare -A sweep_stage=([1]="12.3,140 800 12" [2]="51.0,-60 600 32")
declare -A train_stage=([1]="23.5,-120 500 21" [2]="8.1,130 700 41")
declare -A run_stage=([1A]="7.25,150 1000 61" [2A]="19.6,-95 1000 62" [1B]="42.3,-180 250 63" [2B]="3.1,90 600 64")
declare -A path_file=([A]=lab_path.csv [B]=path_b.csv) path_seconds=([A]=300 [B]=240)

# The JSON of robot N's effects in the doc (the text between the backticks after its marker).
python3 - "$repo/docs/lab_loop.md" "$robot_effects_1" "$robot_effects_2" <<'PY' ||
import json, re, sys
doc = re.sub(r'\s+', ' ', open(sys.argv[1]).read())
for n, marker in ((1, "this robot's effects file (`"), (2, "(robot 1 above; robot 2: `")):
    at = doc.find(marker)
    if at < 0 or json.loads(doc[at + len(marker):doc.index('`', at + len(marker))]) != json.loads(sys.argv[1 + n]):
        sys.exit('robot %d' % n)
PY
  echo "closed_loop_runs: warning: the robots' effects written here differ from docs/lab_loop.md's (or it no longer names them)" >&2

board=
cleanup() { if [[ -n $board ]]; then kill "$board" 2>/dev/null || true; wait "$board" 2>/dev/null || true; fi; }
trap cleanup EXIT
trap 'exit 130' INT TERM

# A model virtual board in the background (its pid in $board) once its link exists: LINK LOG ARGS...
start_board() {
  local link=$1 log=$2
  shift 2
  "$deltactl" virtual-board --link "$link" --fidelity model "$@" >"$log" 2>&1 &
  board=$!
  for _ in $(seq 600); do
    [[ -e $link ]] && return 0
    kill -0 "$board" 2>/dev/null || break
    sleep 0.1
  done
  echo "virtual board did not start ($log: $(tail -n 1 "$log"))"
  return 1
}
stop_board() {
  kill "$board" 2>/dev/null || true
  wait "$board" 2>/dev/null || true
  board=
}
# STEP LOG COMMAND...: runs it, its output to LOG; on failure one line naming the step and LOG.
step() {
  local name=$1 log=$2 status=0
  shift 2
  "$@" >"$log" 2>&1 || status=$?
  [[ $status -eq 0 ]] || echo "$name failed (exit $status; $log: $(grep -v '^\s*$' "$log" | tail -n 1))"
  return $status
}

# RUN.csv or DATA.csv (t_s,...,x_m,y_m,z_m,...) against the truth at the same board times (the ms):
# prints "rows rms_x rms_y rms_z" in um; with OUT, writes DATA.csv with the truth's plate instead.
against_truth() {
  awk -F, -v OFS=, -v truth="$2" -v out="${3:-}" '
    BEGIN {
      while ((getline line < truth) > 0) if (line !~ /^#/) break
      n = split(line, h, ","); for (i = 1; i <= n; ++i) tc[h[i]] = i
      if (!("t_s" in tc && "x_m" in tc)) { print "truth " truth ": no t_s,x_m,y_m,z_m header" > "/dev/stderr"; exit 2 }
      tms = -1
    }
    /^#/ { next }
    !header {
      header = 1; for (i = 1; i <= NF; ++i) c[$i] = i
      if (out != "") print "# " FILENAME "'"'"'s rows with x/y/z_m the plate of " truth " (the same board time, by the ms)\n" $0 > out
      next
    }
    {
      ms = int($c["t_s"] * 1000 + 0.5)
      while (tms < ms) {
        if ((getline line < truth) <= 0) { tms = 1e18; break }
        split(line, t, ","); tms = int(t[tc["t_s"]] * 1000 + 0.5)
      }
      if (tms != ms) next
      dx = $c["x_m"] - t[tc["x_m"]]; dy = $c["y_m"] - t[tc["y_m"]]; dz = $c["z_m"] - t[tc["z_m"]]
      sx += dx * dx; sy += dy * dy; sz += dz * dz; ++rows
      if (out != "") { $c["x_m"] = t[tc["x_m"]]; $c["y_m"] = t[tc["y_m"]]; $c["z_m"] = t[tc["z_m"]]; print > out }
    }
    END { if (rows) printf "%d %.3f %.3f %.3f\n", rows, sqrt(sx / rows) * 1e6, sqrt(sy / rows) * 1e6, sqrt(sz / rows) * 1e6
          else print "0 nan nan nan" }' "$1"
}

# MERGE.json against the true clock (OFFSET,PPM) and the merged plate against the truth.
merge_summary() {
  local report=$1 clock=$2 truth_rms=$3
  python3 - "$report" "$clock" "$truth_rms" <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))
offset, ppm = map(float, sys.argv[2].split(','))
rows, x, y, z = sys.argv[3].split()
print('%+.3f ms, %+.3f ppm; %s / %s / %s um%s' % ((m['offset_s'] - offset) * 1e3, m['rate_ppm'] - ppm,
      *('%.2g' % float(v) if float(v) < 1 else '%.1f' % float(v) for v in (x, y, z)),
      '' if m.get('offset_signal_left', 1) >= 0.01 else ' (merge: the clocks are poorly fixed)'))
PY
}

# The diagnosis in the table's words: the set (and whether it is the robot's), the verdict, floors, z.
diagnosis_summary() {
  python3 - "$1" "$2" <<'PY'
import json, re, sys
d, robot = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
def nonzero(v):
    return any(nonzero(x) for x in (v.values() if isinstance(v, dict) else v)) if isinstance(v, (dict, list)) else v != 0
own = {name for name, value in robot.items() if nonzero(value)}
# transmission_error's phases alone do not make an effect, its amplitudes do
if 'transmission_error' in robot and not nonzero(robot['transmission_error'].get('amplitude_deg', [0])):
    own.discard('transmission_error')
chosen = re.split(r', or equivalently | explains? the recording| leaves a residual', d['verdict'])[0]
alternatives = [a['effects'] for a in d.get('alternatives', [])]
if set(chosen.split(' + ')) == own:
    relation = "exactly the robot's"
elif any(set(a) == own for a in alternatives):
    relation = "the robot's own among the alternatives"
else:
    missing, extra = sorted(own - set(chosen.split(' + '))), sorted(set(chosen.split(' + ')) - own)
    relation = "not the robot's: " + '; '.join(part for part in (
        'without ' + ', '.join(missing) if missing else '', 'with ' + ', '.join(extra) if extra else '') if part)
also = ''.join('; or ' + ' + '.join(a) for a in alternatives if set(a) != own)
f = d['floor_test']
print('%s (%s%s), %s: %s floors, z %.2f (threshold %.1f)' % (
    chosen, relation, also, 'explained' if d['explained'] else 'not explained',
    ' / '.join('%.3f' % v for v in f['joint_rmse_floors']), f['statistic_z'], f['threshold_z']))
PY
}

# ---- Paths ----------------------------------------------------------------------------------------
# gen_path OUT SECONDS "A F PHASE (x, y, z)" "A F PHASE (x, y, z)": the sum of the two Lissajous
# figures about the cube's centre, 1 kHz, t_s,x_m,y_m,z_m.
gen_path() {
  awk -v seconds="$2" -v slow="$3" -v fast="$4" -v cx="$cx" -v cy="$cy" -v cz="$cz" 'BEGIN {
    split(slow, s, " "); split(fast, f, " "); two_pi = 8 * atan2(1, 1)
    print "t_s,x_m,y_m,z_m"
    n = int(seconds * 1000 + 0.5)
    for (k = 0; k <= n; ++k) {
      t = k / 1000
      for (a = 0; a < 3; ++a)
        p[a] = s[3 * a + 1] * sin(two_pi * s[3 * a + 2] * t + s[3 * a + 3]) + \
               f[3 * a + 1] * sin(two_pi * f[3 * a + 2] * t + f[3 * a + 3])
      printf "%.3f,%.9g,%.9g,%.9g\n", t, cx + p[0], cy + p[1], cz + p[2]
    }
  }' >"$1"
}
# Joint speeds along PATH.csv (nominal inverse kinematics, over 0.1 s): "max M deg/s, P % below 1.5".
joint_speeds() {
  "$deltactl" ik --model nominal --in "$1" --out "$1.ik" >/dev/null 2>&1
  awk -F, 'NR > 1 { for (j = 1; j <= 3; ++j) a[NR % 101, j] = $j
                    if (NR > 101) for (j = 1; j <= 3; ++j) {
                      v = (a[NR % 101, j] - a[(NR + 1) % 101, j]) * 10; v = v < 0 ? -v : v
                      if (v > max) max = v; below += v < 1.5; ++n } }
           END { printf "joints (nominal) up to %.1f deg/s, below 1.5 deg/s %.0f %% of the time", max, 100 * below / n }' "$1.ik"
  rm -f "$1.ik"
}

# ---- Per robot: effects, the held-out sweep, the deployed model -----------------------------------
status=0
# DIR NAME STAGE SECONDS EFFECTS TRAJECTORY: a drag on the free-running model board, homed first
# (the stage takes hold as host record starts, docs/lab_loop.md), merged.
drag() {
  local dir=$1 name=$2 trajectory=$6 clock rate seed
  read -r clock rate seed <<<"$3"
  start_board "$dir/tty" "$dir/${name}_board.log" --free-run --effects "$5" --truth "$dir/${name}_truth.csv" \
    --stage "drag:$trajectory" --stage-after-home 0 --stage-log "$dir/${name}_stage.csv" --stage-clock "$clock" \
    --stage-rate "$rate" --stage-seed "$seed" || return 1
  step "$name: host home" "$dir/${name}_home.log" "$deltactl" host home --port "$dir/tty" \
    --weights "$repo/weights/paper_like_deployed.json" || { stop_board; return 1; }
  step "$name: host record" "$dir/${name}_record.log" "$deltactl" host record --port "$dir/tty" \
    --out "$dir/${name}_run.csv" --duration "$4" --link-timeout-ms 3000 || { stop_board; return 1; }
  stop_board
  step "$name: merge" "$dir/${name}_merge.log" "$deltactl" merge --run "$dir/${name}_run.csv" \
    --stage "$dir/${name}_stage.csv" --out "$dir/$name.csv" --report "$dir/${name}_merge.json" || return 1
  echo "  $name drag ($4 s of $trajectory, stage $clock at $rate Hz, seed $seed): merge $(merge_summary \
    "$dir/${name}_merge.json" "$clock" "$(against_truth "$dir/$name.csv" "$dir/${name}_truth.csv")")"
}
prepare() {
  local n=$1 dir=$work/robot$1/prep
  mkdir -p "$dir"
  if [[ -z ${sweep_of[$n]:-} ]]; then
    drag "$dir" sweep "${sweep_stage[$n]}" "$sweep_seconds" "${effects_of[$n]}" sweep || return 1
    sweep_of[$n]=$dir/sweep.csv
  fi
  if [[ -z ${weights_of[$n]:-} ]]; then
    drag "$dir" "$train_on" "${train_stage[$n]}" "$train_seconds" "${effects_of[$n]}" "$train_on" || return 1
    step "train" "$dir/train.log" "$deltactl" train --data "$dir/$train_on.csv" --out "$dir/W.json" \
      --threads "$train_threads" || return 1
    weights_of[$n]=$dir/W.json
    echo "  trained $dir/W.json on the merged $train_on drag"
  fi
}
for n in "${robot_list[@]}"; do
  mkdir -p "$work/robot$n"
  if [[ -z ${effects_of[$n]:-} ]]; then
    effects_of[$n]=$work/robot$n/effects.json
    doc_effects=robot_effects_$n
    printf '%s\n' "${!doc_effects}" >"${effects_of[$n]}"
  fi
  echo "robot $n: effects ${effects_of[$n]}"
  if [[ -z ${sweep_of[$n]:-} || -z ${weights_of[$n]:-} ]]; then
    if ! prepare "$n"; then status=1; echo "robot $n: preparation FAILED"; continue; fi
  fi
  echo "robot $n: held out ${sweep_of[$n]}, deployed model ${weights_of[$n]}"
done
[[ $prepare_only -eq 0 ]] || exit $status
# The paths about the middle of what every robot's deployed model was trained on (W.json's input
# range, the plate in metres), so that `host run` takes them.
deployed=()
for n in "${robot_list[@]}"; do [[ -z ${weights_of[$n]:-} ]] || deployed+=("${weights_of[$n]}"); done
[[ ${#deployed[@]} -gt 0 ]] || exit $status
read -r cx cy cz < <(python3 - "${deployed[@]}" <<'PY'
import json, sys
low, high = [-1e9] * 3, [1e9] * 3
for path in sys.argv[1:]:
    w = json.load(open(path))
    low = [max(a, b) for a, b in zip(low, w['input_min'])]
    high = [min(a, b) for a, b in zip(high, w['input_max'])]
print(' '.join('%.6f' % (0.5 * (a + b)) for a, b in zip(low, high)))
PY
)
mkdir -p "$work/paths"
if [[ $prepare_only -eq 0 ]]; then
  for p in "${path_list[@]}"; do
    file=$work/paths/${path_file[$p]}
    case $p in
      A) gen_path "$file" 300 "3.6e-3 0.013 0 3.6e-3 0.017 1.1 1.9e-3 0.011 0.4" "0.5e-3 0.10 0.7 0.5e-3 0.23 2.3 0.3e-3 0.16 1.9" ;;
      B) gen_path "$file" 240 "3.2e-3 0.07 0 3.0e-3 0.11 1.1 1.6e-3 0.05 0.4" "0.3e-3 0.53 0.7 0.3e-3 0.91 2.3 0.3e-3 0.67 1.9" ;;
    esac
    echo "path $p: $file, ${path_seconds[$p]} s$([[ -n $seconds ]] && echo " (run for $seconds s)"), $(joint_speeds "$file")"
  done
fi

# ---- The closed-loop runs -------------------------------------------------------------------------
table=$work/closed_loop_runs.md
{
  echo "| robot, path | merge: found offset - true, rate - true; merged plate - truth (RMS x / y / z) | diagnose (FIT: the closed-loop run; held out: the sweep drag), held-out floors per joint |"
  echo "|---|---|---|"
} | tee "$table"
row() { echo "$1" | tee -a "$table"; }

# ROBOT PATH: one closed-loop run, its merge and diagnosis (and the true plate's), one row each.
closed_loop_run() {
  local n=$1 p=$2 dir=$work/robot$1/$2 clock rate seed duration=()
  local weights=${weights_of[$1]} sweep=${sweep_of[$1]} effects=${effects_of[$1]}
  read -r clock rate seed <<<"${run_stage[$n$p]}"
  rm -rf "$dir" && mkdir -p "$dir"
  [[ -z $seconds ]] || duration=(--duration "$seconds")
  start_board "$dir/tty" "$dir/board.log" --effects "$effects" --weights "$weights" --truth "$dir/run_truth.csv" \
    --stage follow --stage-log "$dir/run_stage.csv" --stage-clock "$clock" --stage-rate "$rate" \
    --stage-seed "$seed" || return 1
  step "host home" "$dir/home.log" "$deltactl" host home --port "$dir/tty" --weights "$weights" ||
    { stop_board; return 1; }
  step "host run" "$dir/run.log" "$deltactl" host run --port "$dir/tty" --weights "$weights" \
    --trajectory "$work/paths/${path_file[$p]}" "${duration[@]}" --record "$dir/run.csv" ||
    { stop_board; return 1; }
  stop_board
  step "merge" "$dir/merge.log" "$deltactl" merge --run "$dir/run.csv" --stage "$dir/run_stage.csv" \
    --out "$dir/run_merged.csv" --report "$dir/run_merge.json" || return 1
  local merged
  merged=$(merge_summary "$dir/run_merge.json" "$clock" "$(against_truth "$dir/run_merged.csv" "$dir/run_truth.csv")")
  step "diagnose" "$dir/diagnose.log" "$deltactl" diagnose --data "$dir/run_merged.csv" --holdout "$sweep" \
    --json "$dir/diagnosis.json" --predictions "$dir/diagnosis_pred.csv" || return 1
  row "| $n, $p | $merged | $(diagnosis_summary "$dir/diagnosis.json" "$effects") |"
  if [[ ,$true_plate, == *,$p,* ]]; then
    against_truth "$dir/run_merged.csv" "$dir/run_truth.csv" "$dir/true_plate.csv" >/dev/null
    step "diagnose (true plate)" "$dir/true_plate_diagnose.log" "$deltactl" diagnose --data "$dir/true_plate.csv" \
      --holdout "$sweep" --json "$dir/true_plate_diagnosis.json" --predictions "$dir/true_plate_pred.csv" || return 1
    row "| $n, $p, the true plate in place of the stage | (none) | $(diagnosis_summary "$dir/true_plate_diagnosis.json" "$effects") |"
  fi
  echo "  (robot $n, path $p: stage $clock at $rate Hz, seed $seed; board $(grep -o 'at most [0-9.]* ms behind the wall clock' \
    "$dir/board.log" || echo '(lag not printed)'); files in $dir)"
}
for p in "${path_list[@]}"; do
  for n in "${robot_list[@]}"; do
    [[ -n ${weights_of[$n]:-} && -n ${sweep_of[$n]:-} ]] || continue
    if ! closed_loop_run "$n" "$p"; then status=1; row "| $n, $p | FAILED (above) | |"; fi
  done
done
echo "table: $table"
exit $status
