#!/usr/bin/env bash
# Homing on robots the network was not trained on: for the paper-like robot and two others (their
# effects written below), the co-simulation's plate error for experiment 1 (model board, the plain
# network), then N random starts each (seeded; the seed printed): a model virtual board at those
# true angles, `host home`, `host run` of experiment 1 (5 s). Per start: the largest difference
# between the board's counts after homing and the robot's own encoder reading at that moment (the
# truth), and the plate error on the path (from path time 0.4 s) against the co-simulation's.
#
#   scripts/homing_robots.sh [BUILD_DIR] [N] [SEED]      (defaults: build 5 random)
#
# About 15 s per start (the model board keeps to real time). Exit 1 if a homing or run fails, a
# count differs by a count or more, or a plate error exceeds 1.2 x the co-simulation's.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$here/build}
starts=${2:-5}
seed=${3:-$RANDOM}
deltactl=$build/bin/deltactl
weights=$here/weights/paper_like.json
[[ -x $deltactl ]] || { echo "homing_robots: $deltactl not found (build first)" >&2; exit 2; }
work=$(mktemp -d "${TMPDIR:-/tmp}/homing_robots.XXXXXX")
trap 'kill $(jobs -p) 2>/dev/null || true; rm -rf "$work"' EXIT
cat >"$work/robot_b.json" <<'JSON'
{"joint_offset": [0.62, -0.31, 0.84], "upper_arm_length": [0.00012, -0.00009, 0.00021],
 "lower_arm_length": [-0.00025, 0.00031, 0.00008], "radius_offset": [0.0003, -0.0006, 0.0002],
 "chain_angle": [0.31, -0.22, 0.45],
 "frame_misalignment": {"rx": 0.12, "ry": -0.3, "rz": -4.2, "tx": -0.0001, "ty": 0.0002, "tz": -0.0003},
 "backlash": [0.05, 0.12, 0.08], "encoder_scale": [-0.002, 0.003, 0.001]}
JSON
cat >"$work/robot_c.json" <<'JSON'
{"joint_offset": [-0.9, 0.45, -0.2], "upper_arm_length": [-0.0002, 0.00015, 0.0],
 "lower_arm_length": [0.0004, 0.0001, -0.0002], "radius_offset": [-0.0008, 0.0004, 0.0006],
 "backlash": [0.02, 0.02, 0.2],
 "transmission_error": {"amplitude_deg": [0.01, 0.02, 0.015], "period_deg": [6.0, 7.5, 9.0], "phase_rad": [0.0, 0.5, 1.5]},
 "encoder_scale": [0.004, -0.001, -0.003]}
JSON
echo "seed $seed"
status=0
index=0
for robot in "$here/sim/paper_like_effects.json" "$work/robot_b.json" "$work/robot_c.json"; do
  name=$(basename "$robot" .json)
  index=$((index + 1))
  cosim=$("$deltactl" cosim --weights "$weights" --effects "$robot" --trajectory experiment1 --duration 5 \
            --fidelity model 2>/dev/null | awk -F'|' '/closed loop: model board/ {gsub(/ /, "", $6); print $6}')
  echo "$name: co-simulation plate error $cosim um RMS"
  for k in $(seq "$starts"); do
    angles=$(python3 -c "import random; r = random.Random($seed * 1000 + 100 * $index + $k); c = r.uniform(12, 55); print(','.join('%.2f' % (c + r.uniform(-6, 6)) for _ in range(3)))")
    d=$work/$name.$k
    mkdir -p "$d"
    "$deltactl" virtual-board --link "$d/tty" --weights "$weights" --effects "$robot" --fidelity model \
      --truth "$d/truth.csv" --start-angles "$angles" >"$d/board.out" 2>"$d/board.err" &
    board=$!
    for _ in $(seq 600); do [[ -e $d/tty ]] && break; sleep 0.1; done
    home=0 run=0
    "$deltactl" host home --port "$d/tty" --weights "$weights" --quiet >"$d/home.log" 2>&1 || home=$?
    "$deltactl" host status --port "$d/tty" --json >"$d/status.json"
    "$deltactl" host run --port "$d/tty" --weights "$weights" --trajectory experiment1 --duration 5 \
      --record "$d/run.csv" >"$d/run.log" 2>&1 || run=$?
    kill "$board"; wait "$board" 2>/dev/null || true
    python3 - "$d" "$angles" "$home" "$run" "$cosim" <<'PY' || status=1
import csv, json, math, sys
d, angles, home, run, cosim = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), float(sys.argv[5])
if home or run:
    print('  start %s: FAILED (home exit %d, run exit %d; %s)' % (angles, home, run, d)); sys.exit(1)
rows = lambda p: list(csv.DictReader(l for l in open(p) if not l.startswith('#')))
truth, out, status = rows(d + '/truth.csv'), rows(d + '/run.csv'), json.load(open(d + '/status.json'))
at = max(i for i, r in enumerate(truth) if float(r['t_s']) <= status['tick'] / 1e4)
count = max(abs(status['encoder_deg'][j] - float(truth[at]['encoder%d_deg' % (j + 1)])) for j in range(3))
by_ms = {round(float(r['t_s']) * 1000): r for r in truth}
sum_sq = n = 0
for r in out:
    t = by_ms.get(round(float(r['t_s']) * 1000))
    if r['drives_enabled'] != '1' or float(r['tau_s']) < 0.4 or t is None: continue
    sum_sq += sum((float(t[a]) - float(r[a[0] + '_ref_m'])) ** 2 for a in ('x_m', 'y_m', 'z_m')); n += 1
rms = math.sqrt(sum_sq / n) * 1e6
ok = count < 0.005 and rms <= 1.2 * cosim
print('  start %s: counts - robot encoder max %.2f deg; plate error %.2f um RMS = %.3f x the co-simulation%s'
      % (angles, count, rms, rms / cosim, '' if ok else '  FAILED'))
sys.exit(0 if ok else 1)
PY
  done
done
exit $status
