#!/usr/bin/env bash
# Set-up, configure and build (Release, Ninja, build/). Extra arguments go to `cmake --build`.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
bash scripts/setup.sh
if [[ ! -f build/CMakeCache.txt ]]; then
  cmake --preset default >/dev/null
fi
cmake --build build -j "$(nproc)" "$@"
