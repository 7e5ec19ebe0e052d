#!/usr/bin/env bash
# Set-up, configure and build (Release, Ninja, build/). Extra arguments go to `cmake --build`.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
bash scripts/setup.sh
if [[ ! -f build/CMakeCache.txt ]]; then
  # ccache (scripts/setup.sh; CMakeLists.txt) makes a rebuild of unchanged sources, e.g. in a fresh clone, a cache hit.
  cmake --preset default >/dev/null
fi
cmake --build build -j "$(nproc)" "$@"
