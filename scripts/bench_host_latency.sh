#!/usr/bin/env bash
# Benchmark (not a CTest test): the wake latency of the host controller's 1 kHz loop (absolute
# CLOCK_MONOTONIC deadlines, `deltactl host latency`, the same code as the streaming thread) over
# SECONDS, with SCHED_FIFO 80 and locked memory, then with normal scheduling, in the same run, and
# graded in LinuxCNC's latency-test bands by the worst case. SCHED_FIFO needs root or an RT limit
# (deltactl.service has LimitRTPRIO=90); without it the first row says so.
# Usage: scripts/bench_host_latency.sh [BUILD_DIR] [SECONDS]   (defaults: build, 60)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
seconds=${2:-60}
deltactl="$build/bin/deltactl"
[[ -x $deltactl ]] || { echo "bench_host_latency: $deltactl missing: bash scripts/build.sh" >&2; exit 2; }

band() {  # LinuxCNC's bands for the worst wake-up latency, microseconds
  awk -v m="$1" 'BEGIN { if (m < 20) print "very good"; else if (m < 50) print "good";
    else if (m < 100) print "acceptable"; else if (m < 500) print "poor"; else print "not acceptable" }'
}
field() { sed -n "s/.*\"$1\":\([-0-9.e+]*\).*/\1/p" <<<"$2"; }

echo "host loop wake latency: 1 kHz, ${seconds} s each, $(uname -r) on $(nproc) cores"
printf '%-22s %8s %8s %8s %8s %9s  %s\n' scheduling p50_us p99_us p99.9_us max_us overruns band
for mode in fifo normal; do
  flag=""
  [[ $mode == normal ]] && flag="--normal"
  json=$("$deltactl" host latency --seconds "$seconds" --json $flag)
  scheduling=$(sed -n 's/.*"scheduling":"\([^"]*\)".*/\1/p' <<<"$json")
  max=$(field max_us "$json")
  printf '%-22s %8.0f %8.0f %8.0f %8.0f %9s  %s\n' "$scheduling" "$(field p50_us "$json")" "$(field p99_us "$json")" \
    "$(field p999_us "$json")" "$max" "$(field overruns "$json")" "$(band "$max")"
  note=$(sed -n 's/.*"note":"\([^"]*\)".*/\1/p' <<<"$json")
  [[ $mode == fifo && -n $note ]] && echo "  (SCHED_FIFO not granted: $note)"
done
