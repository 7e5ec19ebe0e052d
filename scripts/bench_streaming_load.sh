#!/usr/bin/env bash
# Benchmark (not a CTest test): streaming on a loaded PC. Beside BUSY busy loops (`yes > /dev/null`),
# RUNS runs of SECONDS of experiment 1 against the model virtual board (kept to real time), each
# `deltactl host home` + `deltactl host run`: exit code and the board's underruns while streaming.
# Then, under the same load, one run whose host is frozen for 100 ms mid-run (SIGSTOP/SIGCONT: it
# must complete, exit 0, no underrun) and one whose host is killed mid-run (SIGKILL: the truth
# gives when the drives went off after the kill, against the board watchdog's 250 ms + 1 period;
# the kill is placed in board time by the wall clock since the board's ready line, +- a few ms).
# The budget these check is docs/board_link.md, "Streaming budget".
# Usage: scripts/bench_streaming_load.sh [BUILD_DIR] [RUNS] [SECONDS] [BUSY]   (defaults: build, 10, 20, 2)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
runs=${2:-10}
seconds=${3:-20}
busy=${4:-2}
deltactl="$build/bin/deltactl"
weights="$root/weights/paper_like.json"
[[ -x $deltactl ]] || { echo "bench_streaming_load: $deltactl missing: bash scripts/build.sh" >&2; exit 2; }

work=$(mktemp -d /tmp/bench_streaming_load.XXXXXX)
loads=()
board=""
cleanup() {
  [[ -n $board ]] && kill "$board" 2>/dev/null && wait "$board" 2>/dev/null
  for pid in "${loads[@]}"; do kill "$pid" 2>/dev/null; done
  rm -rf "$work"
}
trap cleanup EXIT
for ((i = 0; i < busy; i++)); do
  yes > /dev/null &
  loads+=($!)
done

now() { date +%s.%N; }
start_board() {  # $1: run name; sets board, ready_at
  local name=$1
  "$deltactl" virtual-board --fidelity model --weights "$weights" --link "$work/$name.tty" \
    --truth "$work/$name.truth.csv" > "$work/$name.board.out" 2> "$work/$name.board.err" &
  board=$!
  for ((t = 0; t < 6000; t++)); do
    grep -q "ready" "$work/$name.board.out" 2>/dev/null && break
    sleep 0.01
  done
  ready_at=$(now)
  "$deltactl" host home --port "$work/$name.tty" --weights "$weights" --link-timeout-ms 2000 --quiet > /dev/null
}
stop_board() {
  kill -INT "$board"
  wait "$board" || true
  board=""
}
run_args() {  # $1: run name
  echo "$deltactl" host run --port "$work/$1.tty" --weights "$weights" --trajectory experiment1 --duration "$seconds" \
    --record "$work/$1.csv"
}
underruns() { sed -n 's/.*underruns while streaming \([0-9]*\).*/\1/p' "$1" | head -1; }

echo "streaming under load: $busy busy loops, $(nproc) cores, load $(cut -d' ' -f1 /proc/loadavg);" \
  "experiment 1 for $seconds s, model board at real time"
printf '%-10s %5s %10s  %s\n' run exit underruns note
ok=0
for ((r = 1; r <= runs; r++)); do
  start_board "run$r"
  set +e
  $(run_args "run$r") > "$work/run$r.out" 2> "$work/run$r.err"
  code=$?
  set -e
  stop_board
  u=$(underruns "$work/run$r.out")
  [[ $code == 0 && $u == 0 ]] && ok=$((ok + 1))
  printf '%-10s %5s %10s  %s\n' "run $r" "$code" "${u:--}" "$(grep -o 'deltactl: error: .*' "$work/run$r.err" | head -1)"
done
echo "plain runs: $ok of $runs with exit 0 and no underrun"

# The host frozen for 100 ms half way.
start_board stop100
set +e
$(run_args stop100) > "$work/stop100.out" 2> "$work/stop100.err" &
host=$!
sleep "$(awk -v s="$seconds" 'BEGIN { print s / 2 }')"
kill -STOP "$host" || true
sleep 0.1
kill -CONT "$host" || true
wait "$host"
code=$?
set -e
stop_board
printf '%-10s %5s %10s  %s\n' "SIGSTOP" "$code" "$(underruns "$work/stop100.out")" "host frozen 100 ms mid-run"

# The host killed half way: drives off after the kill, from the truth.
start_board kill
$(run_args kill) > "$work/kill.out" 2> "$work/kill.err" &
host=$!
sleep "$(awk -v s="$seconds" 'BEGIN { print s / 2 }')"
alive=yes
kill -0 "$host" 2>/dev/null || alive="no: the run had ended before the kill, see $work/kill.err"
kill -KILL "$host" || true
killed_at=$(now)
wait "$host" 2>/dev/null || true
sleep 1
stop_board
kill_s=$(awk -v k="$killed_at" -v r="$ready_at" 'BEGIN { printf "%.4f", k - r }')
off_s=$(awk -F, -v k="$kill_s" 'NR > 1 { if ($8 == 1) { on = $1; off = "" } else if (on != "" && off == "") off = $1 }
  END { print off }' "$work/kill.truth.csv")
[[ $alive == yes ]] || echo "SIGKILL: host alive at the kill: $alive"
printf '%-10s %5s %10s  %s %s\n' "SIGKILL" "-" "-" "drives off at $off_s s of board time, the kill at ~$kill_s s:" \
  "$(awk -v o="$off_s" -v k="$kill_s" 'BEGIN { printf "%.1f ms after it (bound 250.1 ms)", (o - k) * 1e3 }')"
