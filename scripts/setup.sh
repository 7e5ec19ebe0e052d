#!/usr/bin/env bash
# Installs everything the project uses from Debian's packages; quick and silent when all is present.
set -euo pipefail

packages=(
  g++ cmake ninja-build pkg-config ccache  # build (ccache: rebuilds of the same sources are cache hits)
  libeigen3-dev nlohmann-json3-dev libcli11-dev libgtest-dev libmatio-dev zlib1g-dev  # libraries
  verilator libsystemc-dev                 # RTL simulation (C++ and SystemC testbenches)
  yosys nextpnr-ice40 fpga-icestorm iverilog  # FPGA flow and gate-level simulation
  z3                                       # formal proofs (scripts/formal.sh): yosys-smtbmc's solver
  gnuplot-nox                              # PNG plots
  clang-format                             # C++ layout (.clang-format; CTest Format.*)
  python3-serial socat                     # independent serial clients for the link tests
  lintian systemd                          # the Debian package: lintian, systemd-analyze verify of the unit
  clang-14 libclang-rt-14-dev              # libFuzzer harnesses of the readers (scripts/fuzz.sh)
  libcpp-httplib-dev                       # the dashboard's HTTP server (host serve --http)
  chromium                                 # the dashboard's real-browser test (headless)
)

missing=()
for package in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$package" 2>/dev/null || true)
  [[ "$status" == "install ok installed" ]] || missing+=("$package")
done
if ((${#missing[@]} == 0)); then
  exit 0
fi

echo "setup: installing ${missing[*]}" >&2
sudo=""
if [[ $(id -u) -ne 0 ]]; then
  command -v sudo >/dev/null || { echo "setup: need root (or sudo) to apt-get install ${missing[*]}" >&2; exit 1; }
  sudo="sudo"
fi
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "setup: done" >&2
