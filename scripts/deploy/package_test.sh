#!/usr/bin/env bash
# The Debian packages of the host-only build (CTest Deploy.Package): `cpack -G DEB` in BUILD_DIR,
# and the companion deltactl-gateware built by scripts/deploy/gateware_package.sh from a stand-in
# bitstream (an empty design of the UP5K's layout, BLANK_BITSTREAM_TOOL; the real one takes
# nextpnr minutes: `cmake --build build --target gateware_package`) with the identify.mem of this
# build's gateware and the shipped weights. Checks: lintian with no errors and no hardening tags,
# the contents (deltactl, weights, unit, udev rules, the conffile, maintainer scripts, Depends on
# deltactl-gateware of the same version), BIND_NOW; then both installed into a scratch root with
# dpkg -x: the installed deltactl runs (--help), checks the installed configuration, and
# `deltactl flash --dry-run` with it exits 0 naming the installed bitstream (paths moved into the
# scratch root). Given a full build's deltactl (it has `virtual-board`; the package has not), the
# installed deltactl then drives the virtual board through its pty: `host home`, a 1 s `host run`
# of experiment 1 with the installed weights, and `host serve` started as the unit's ExecStart does
# (the installed config, port and socket moved into the scratch folder) under a NOTIFY_SOCKET that
# must receive READY=1, answering `host ctl status`, stopped by SIGTERM.
# Usage: scripts/deploy/package_test.sh BUILD_DIR BLANK_BITSTREAM_TOOL [FULL_BUILD_DELTACTL]
set -euo pipefail
build=${1:?usage: package_test.sh BUILD_DIR BLANK_BITSTREAM_TOOL [FULL_BUILD_DELTACTL]}
blank_tool=${2:?usage: package_test.sh BUILD_DIR BLANK_BITSTREAM_TOOL [FULL_BUILD_DELTACTL]}
full_deltactl=${3:-}
src=$(cd "$(dirname "$0")/../.." && pwd)
fail() { echo "FAIL: $*" >&2; exit 1; }
command -v lintian >/dev/null || { echo "SKIP: no lintian (scripts/setup.sh installs it)"; exit 77; }
work=$(mktemp -d)
board_pid=""
serve_pid=""
cleanup() {
  [[ -n $serve_pid ]] && kill "$serve_pid" 2>/dev/null || true
  [[ -n $board_pid ]] && kill "$board_pid" 2>/dev/null || true
  wait 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT
(cd "$build" && cpack -G DEB -B "$work/out" >"$work/cpack.log" 2>&1) || { cat "$work/cpack.log" >&2; fail "cpack"; }
deb=$(ls "$work"/out/deltactl_*.deb) || fail "no deltactl_*.deb"
# The companion package, from a stand-in bitstream and this build's identify of the shipped weights.
mkdir "$work/gateware"
"$build/bin/deltactl" quantise --weights "$src/weights/paper_like_deployed.json" --out-dir "$work/gateware" >/dev/null
"$blank_tool" "$work/gateware/icebreaker_top.bin"
bash "$src/scripts/deploy/gateware_package.sh" "$work/gateware/icebreaker_top.bin" "$work/gateware/identify.mem" \
  "$src/host/deploy/debian/changelog" "$src/host/deploy/debian/copyright" "$work/out" >/dev/null
gateware_deb=$(ls "$work"/out/deltactl-gateware_*_all.deb) || fail "no deltactl-gateware_*_all.deb"
# lintian: no errors, and none of its hardening-* tags (warnings and info are printed, not fatal).
for package in "$deb" "$gateware_deb"; do
  if ! lintian --fail-on error --display-info --tag-display-limit 0 "$package" >"$work/lintian.log" 2>&1; then
    cat "$work/lintian.log" >&2; fail "lintian reports errors for $(basename "$package")"
  fi
  if grep -E '^[EWI]: .*hardening-' "$work/lintian.log" >&2; then fail "lintian: hardening tags for $(basename "$package")"; fi
  grep -c '^W:' "$work/lintian.log" >>"$work/warnings" || true
done
warnings=$(awk "{ s += \$1 } END { print s + 0 }" "$work/warnings")
dpkg-deb --info "$deb" >"$work/info"
version=$(dpkg-deb -f "$deb" Version)
grep -q '^ Package: deltactl$' "$work/info" || fail "package name"
grep -q '^ Depends: .*adduser' "$work/info" || fail "Depends lacks adduser"
grep -q "^ Depends: .*deltactl-gateware (= $version)" "$work/info" || fail "Depends lacks deltactl-gateware (= $version)"
[[ $(dpkg-deb -f "$gateware_deb" Version) == "$version" ]] || fail "deltactl-gateware's version is not $version"
[[ $(dpkg-deb -f "$gateware_deb" Architecture) == all ]] || fail "deltactl-gateware is not Architecture: all"
grep -q '^ Suggests: .*fpga-icestorm' "$work/info" || fail "Suggests lacks fpga-icestorm"
dpkg-deb --ctrl-tarfile "$deb" | tar -t >"$work/control"
for script in ./postinst ./prerm ./postrm ./conffiles; do grep -qx "$script" "$work/control" || fail "no $script"; done
dpkg-deb --ctrl-tarfile "$deb" | tar -xO ./conffiles | grep -qx /etc/deltactl/deltactl.conf || fail "conffiles"
dpkg-deb --ctrl-tarfile "$deb" | tar -xO ./postinst | grep -q 'adduser --system' || fail "postinst makes no user"
root="$work/root"
dpkg -x "$deb" "$root"
dpkg -x "$gateware_deb" "$root"
for file in usr/bin/deltactl usr/share/deltactl/weights/paper_like_deployed.json lib/systemd/system/deltactl.service \
            lib/udev/rules.d/70-delta-board.rules etc/deltactl/deltactl.conf usr/share/doc/deltactl/copyright \
            usr/share/doc/deltactl/lab_setup.md usr/share/deltactl/gateware/icebreaker_top.bin \
            usr/share/deltactl/gateware/identify.mem usr/share/doc/deltactl-gateware/copyright; do
  [[ -e "$root/$file" ]] || fail "package lacks /$file"
done
readelf -d "$root/usr/bin/deltactl" | grep -Eq 'BIND_NOW|FLAGS.*NOW' || fail "deltactl is not linked with -z now"
"$root/usr/bin/deltactl" --help >"$work/help" || fail "installed deltactl --help"
for command in doctor flash config; do grep -q "^  $command" "$work/help" || fail "installed deltactl lacks $command"; done
sed "s#/usr/share/deltactl#$root/usr/share/deltactl#" "$root/etc/deltactl/deltactl.conf" >"$work/deltactl.conf"
"$root/usr/bin/deltactl" config check --config "$work/deltactl.conf" >/dev/null || fail "installed config check"
installed="$root/usr/bin/deltactl"
# Out of the box: the installed configuration names the installed bitstream, of this deltactl's gateware.
"$installed" flash --dry-run --config "$work/deltactl.conf" >"$work/flash.log" 2>&1 || { cat "$work/flash.log" >&2; fail "installed flash --dry-run"; }
grep -qx "command: iceprog $root/usr/share/deltactl/gateware/icebreaker_top.bin" "$work/flash.log" ||
  { cat "$work/flash.log" >&2; fail "flash --dry-run does not program the installed bitstream"; }
run_note="no virtual board (host-only tree): the installed host run is not exercised"
if [[ -n $full_deltactl ]]; then
  weights="$root/usr/share/deltactl/weights/paper_like_deployed.json"
  tty="$work/tty"
  "$full_deltactl" virtual-board --link "$tty" --weights "$weights" --fidelity model --truth "$work/truth.csv" \
    >"$work/board.log" 2>&1 &
  board_pid=$!
  for _ in $(seq 600); do [[ -e $tty ]] && break; sleep 0.1; done
  [[ -e $tty ]] || { cat "$work/board.log" >&2; fail "virtual board never made $tty"; }
  "$installed" host home --port "$tty" --weights "$weights" --link-timeout-ms 2000 >"$work/home.log" 2>&1 || { cat "$work/home.log" >&2; fail "installed host home"; }
  if ! "$installed" host run --port "$tty" --weights "$weights" --trajectory experiment1 --duration 1 \
      --record "$work/run.csv" --link-timeout-ms 1000 >"$work/run.log" 2>&1; then
    cat "$work/run.log" >&2; fail "installed host run of 1 s"
  fi
  rows=$(grep -vc '^#' "$work/run.csv")
  ((rows > 1000)) || fail "installed host run recorded $rows rows"
  # The service's command line, with the installed configuration pointed at the pty and a socket here.
  sed -i "s#^port = .*#port = $tty#; s#^socket = .*#socket = $work/ctl.sock#" "$work/deltactl.conf"
  /usr/bin/python3 - "$work/notify.sock" >"$work/notify.log" 2>&1 <<'PY' &
import socket, sys
s = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
s.bind(sys.argv[1])
s.settimeout(60)
while True:
    message = s.recv(4096).decode()
    print(message, flush=True)
    if "READY=1" in message:
        break
PY
  notify_pid=$!
  for _ in $(seq 100); do [[ -S $work/notify.sock ]] && break; sleep 0.05; done
  NOTIFY_SOCKET="$work/notify.sock" STATE_DIRECTORY="$work/state" "$installed" host serve --config "$work/deltactl.conf" \
    >"$work/serve.log" 2>&1 &
  serve_pid=$!
  wait "$notify_pid" || { cat "$work/serve.log" >&2; fail "host serve sent no READY=1 to NOTIFY_SOCKET"; }
  for _ in $(seq 100); do
    "$installed" host ctl --socket "$work/ctl.sock" status --json >"$work/status.json" 2>/dev/null &&
      grep -q '"connection":"connected"' "$work/status.json" && break
    sleep 0.1
  done
  grep -q '"state":"homed"' "$work/status.json" || { cat "$work/status.json" "$work/serve.log" >&2; fail "installed host serve: status"; }
  kill -TERM "$serve_pid"
  wait "$serve_pid" || fail "installed host serve did not exit 0 on SIGTERM"
  serve_pid=""
  run_note="installed host run 1 s: $rows rows; installed host serve (the unit's command line): READY=1, status homed, SIGTERM exit 0"
fi
echo "PASS: $(basename "$deb") ($(du -h "$deb" | cut -f1)) and $(basename "$gateware_deb"): lintian no errors, no" \
  "hardening tags ($warnings warnings); installed: deltactl runs, flash --dry-run exit 0; $run_note"
