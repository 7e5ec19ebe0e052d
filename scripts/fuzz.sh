#!/usr/bin/env bash
# libFuzzer harnesses of the input readers (tests/fuzz): build with clang, then run.
#   scripts/fuzz.sh build                     configure and build build-fuzz/ (exit 77: no clang/libFuzzer)
#   scripts/fuzz.sh run HARNESS SECONDS       short run (CI): SECONDS of fuzzing on the kept corpus
#   scripts/fuzz.sh long [RUNS] [HARNESS...]  each harness (default all) for RUNS executions (default 1000000),
#                                             new corpus entries merged into tests/fuzz/corpus/
# Harnesses: csv effects weights mat. A finding leaves crash-* / leak-* files in build-fuzz/findings/.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build="${DELTA_FUZZ_BUILD:-$root/build-fuzz}"
harnesses=(csv effects weights mat)

compiler() {
  for candidate in clang++-14 clang++; do
    if command -v "$candidate" >/dev/null; then echo "$candidate"; return; fi
  done
}

case "${1:-}" in
  build)
    cxx=$(compiler)
    if [[ -z "$cxx" ]]; then echo "fuzz: no clang++ (scripts/setup.sh installs clang-14 libclang-rt-14-dev)" >&2; exit 77; fi
    if ! echo 'extern "C" int LLVMFuzzerTestOneInput(const char*, long) { return 0; }' |
        "$cxx" -x c++ -fsanitize=fuzzer - -o /dev/null 2>/dev/null; then
      echo "fuzz: $cxx cannot link -fsanitize=fuzzer (install libclang-rt-14-dev)" >&2; exit 77
    fi
    if [[ ! -f "$build/CMakeCache.txt" ]]; then
      cmake -S "$root/tests/fuzz" -B "$build" -G Ninja -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
    fi
    cmake --build "$build" -j "$(nproc)"
    ;;
  run)
    harness=$2 seconds=$3
    [[ -x "$build/fuzz_$harness" ]] || { echo "fuzz: build first (scripts/fuzz.sh build)" >&2; exit 77; }
    work=$(mktemp -d)
    trap 'rm -rf "$work"' EXIT
    mkdir -p "$build/findings"
    # New inputs go to the scratch folder; the kept corpus is only read.
    "$build/fuzz_$harness" -max_total_time="$seconds" -rss_limit_mb=1024 -timeout=10 -print_final_stats=1 \
      -artifact_prefix="$build/findings/${harness}-" "$work" "$root/tests/fuzz/corpus/$harness" 2>"$work/log" ||
      { tail -40 "$work/log" >&2; exit 1; }
    grep -E "stat::number_of_executed_units|Done" "$work/log" | sed "s/^/fuzz $harness: /"
    ;;
  long)
    runs=${2:-1000000}
    if (($# > 2)); then harnesses=("${@:3}"); fi
    mkdir -p "$build/findings"
    for harness in "${harnesses[@]}"; do
      work=$(mktemp -d)
      start=$(date +%s)
      "$build/fuzz_$harness" -runs="$runs" -rss_limit_mb=1024 -timeout=10 -print_final_stats=1 \
        -artifact_prefix="$build/findings/${harness}-" "$work" "$root/tests/fuzz/corpus/$harness" 2>"$work/log" ||
        { tail -40 "$work/log" >&2; echo "fuzz $harness: FINDING (see $build/findings)" >&2; exit 1; }
      executions=$(grep -oE "stat::number_of_executed_units: [0-9]+" "$work/log" | grep -oE "[0-9]+$")
      # Keep only inputs that add coverage to the kept corpus.
      "$build/fuzz_$harness" -merge=1 "$root/tests/fuzz/corpus/$harness" "$work" 2>/dev/null
      echo "fuzz $harness: $executions executions in $(( $(date +%s) - start )) s, no finding"
      rm -rf "$work"
    done
    ;;
  *)
    sed -n '2,8p' "$0" >&2
    exit 2
    ;;
esac
