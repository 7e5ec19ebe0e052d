#!/usr/bin/env bash
# The host-only build (the lab PC's package): configures and builds deltactl with
# -DDELTA_HOST_ONLY=ON, checks that it links neither SystemC nor a Verilated model, and runs it.
# Usage: scripts/host_only_build.sh BUILD_DIR   (CTest HostOnlyBuild runs it into build/host-only)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:?usage: host_only_build.sh BUILD_DIR}
# The compiler cache as in the main build (CMakeLists.txt, cmake/Ccache.cmake).
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DDELTA_HOST_ONLY=ON >/dev/null
cmake --build "$build" -j "$(nproc)" --target deltactl >/dev/null
deltactl="$build/bin/deltactl"
if ldd "$deltactl" | grep -i systemc; then
  echo "host-only deltactl links SystemC" >&2; exit 1
fi
if nm -C "$deltactl" | grep -q -E 'Verilated|sc_core::|sc_dt::'; then
  echo "host-only deltactl contains Verilator or SystemC symbols" >&2; exit 1
fi
"$deltactl" --help >/dev/null
# The fixed-point back end is there; the HLS and RTL ones are not, and say so.
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
printf 'x_m,y_m,z_m\n0.001,-0.002,-0.071\n' >"$work/in.csv"
"$deltactl" ik --weights "$root/weights/paper_like.json" --backend fixed --in "$work/in.csv" --out "$work/out.csv" >/dev/null
grep -q alpha1_raw "$work/out.csv"
if "$deltactl" ik --weights "$root/weights/paper_like.json" --backend rtl --in "$work/in.csv" --out "$work/rtl.csv" 2>"$work/err"; then
  echo "host-only deltactl accepted --backend rtl" >&2; exit 1
fi
echo "host-only build: deltactl without SystemC or Verilator ($(du -h "$deltactl" | cut -f1)); ik --backend fixed runs; rtl refused: $(head -1 "$work/err")"
