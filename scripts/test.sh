#!/usr/bin/env bash
# All tests: set-up, build everything, run the CTest suite on both cores, then say where the time
# went: the build's seconds and compiler-cache hits, the tests' seconds and the 15 slowest tests
# (from CTest's own JUnit record, build/Testing/ctest.xml). Extra arguments go to ctest.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"

# ccache's counters (hits, misses), for the hits of this run's compilations (the build and the
# builds inside tests); empty without ccache.
cache_counters() {
  command -v ccache >/dev/null || return 0
  ccache --print-stats 2>/dev/null |
    awk '$1 == "direct_cache_hit" || $1 == "preprocessed_cache_hit" { hit += $2 } $1 == "cache_miss" { miss = $2 }
         END { print hit + 0, miss + 0 }'
}
cache_delta() {  # BEFORE AFTER -> "H hits of N compilations (P %)"
  local -a before=($1) after=($2)
  local hits=$((after[0] - before[0])) misses=$((after[1] - before[1]))
  local total=$((hits + misses))
  if ((total == 0)); then echo "no compilation"; return; fi
  echo "$hits cache hits of $total compilations ($((100 * hits / total)) %)"
}

start=$(date +%s)
counters_start=$(cache_counters)
bash scripts/build.sh
built=$(date +%s)
counters_built=$(cache_counters)

junit=build/Testing/ctest.xml
mkdir -p build/Testing
status=0
ctest --preset default --output-junit "$root/$junit" "$@" || status=$?
finished=$(date +%s)
counters_end=$(cache_counters)

echo
if [[ -f $junit ]]; then python3 scripts/slowest_tests.py "$junit" 15 || true; fi
echo "build: $((built - start)) s${counters_start:+, $(cache_delta "$counters_start" "$counters_built")}"
echo "tests: $((finished - built)) s${counters_start:+ (builds inside tests: $(cache_delta "$counters_built" "$counters_end"))}"
exit "$status"
