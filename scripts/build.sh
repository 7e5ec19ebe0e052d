#!/usr/bin/env bash
# Set-up, configure and build (Release, Ninja, build/). Extra arguments go to `cmake --build`.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
bash scripts/setup.sh
if [[ ! -f build/CMakeCache.txt ]]; then
  # ccache (scripts/setup.sh) makes a rebuild of unchanged sources, e.g. in a fresh clone, a cache hit.
  if command -v ccache >/dev/null; then export CMAKE_CXX_COMPILER_LAUNCHER=ccache; fi
  cmake --preset default >/dev/null
fi
cmake --build build -j "$(nproc)" "$@"
