#!/usr/bin/env bash
# The diagnosis blind suite: 60 seeded cases (none, every family alone, pairs, unequal rods outside
# the library) and EXTENDED cases of the harder kinds (trading pairs, three effects, small effects,
# stage glitches and a gap, a one-axis stage scale error outside the vocabulary) through
# `deltactl diagnose`; prints one row per case and the score per kind.
# Usage: bash scripts/blind_suite.sh [BUILD_DIR] [CASES] [EXTENDED]   (defaults: build, 60, 40).
# Takes ~20 min on 2 cores.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build}
cases=${2:-60}
extended=${3:-40}
if [[ ! -x "$build/bin/deltactl" || ! -x "$build/bin/diagnosis_blind_suite" ]]; then
  cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
  cmake --build "$build" -j2 --target deltactl diagnosis_blind_suite
fi
work=$(mktemp -d /tmp/delta-blind-suite-XXXXXX)
trap 'rm -rf "$work"' EXIT
"$build/bin/diagnosis_blind_suite" --deltactl "$build/bin/deltactl" --work "$work" --cases "$cases" --extended "$extended"
