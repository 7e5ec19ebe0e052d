#!/usr/bin/env bash
# All tests: set-up, build everything, run the CTest suite on both cores.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
cd "$root"
bash scripts/build.sh
ctest --preset default "$@"
