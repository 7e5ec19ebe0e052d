#!/usr/bin/env bash
# Installs everything the project uses from Debian's packages, and the newer FPGA tools (yosys
# 0.55, nextpnr-ice40 0.8, YoWASP builds) from npm into $DELTA_YOWASP (default
# ~/.cache/delta-yowasp/node_modules, where scripts/ice40_synth.sh finds them); quick and silent
# when all is present. Without npm (or the registry) the FPGA flow keeps Debian's yosys 0.23 and
# nextpnr-ice40 0.4, and says so.
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
# The FPGA tools from npm, pinned (scripts/ice40_synth.sh's synthesis command is theirs); they need
# Node.js 18 or newer and npm on the PATH, which this script does not install.
npm_packages=(@yowasp/yosys@0.55.944 @yowasp/nextpnr-ice40@0.8.621)

# Installs the npm packages that are missing or at another version (after the Debian ones: npm).
install_npm_packages() {
  local root=${DELTA_YOWASP:-$HOME/.cache/delta-yowasp/node_modules} package name version present missing_npm=()
  for package in "${npm_packages[@]}"; do
    name=${package%@*} version=${package##*@}
    present=$(sed -n 's/^  "version": "\(.*\)",$/\1/p' "$root/$name/package.json" 2>/dev/null || true)
    [[ $present == "$version" ]] || missing_npm+=("$package")
  done
  ((${#missing_npm[@]} == 0)) && return 0
  if ! command -v npm >/dev/null || ! command -v node >/dev/null; then
    echo "setup: no npm: the FPGA flow uses Debian's yosys 0.23 and nextpnr-ice40 0.4" >&2
    return 0
  fi
  echo "setup: installing ${missing_npm[*]} (npm) into $root" >&2
  mkdir -p "$(dirname "$root")"
  if ! npm install --silent --no-audit --no-fund --prefix "$(dirname "$root")" "${missing_npm[@]}" >/dev/null; then
    echo "setup: npm install failed: the FPGA flow uses Debian's yosys 0.23 and nextpnr-ice40 0.4" >&2
  fi
}

missing=()
for package in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$package" 2>/dev/null || true)
  [[ "$status" == "install ok installed" ]] || missing+=("$package")
done
if ((${#missing[@]} == 0)); then
  install_npm_packages
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
install_npm_packages
echo "setup: done" >&2
