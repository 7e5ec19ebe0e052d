#!/usr/bin/env bash
# The Debian package of the host-only build (CTest Deploy.Package): `cpack -G DEB` in BUILD_DIR,
# lintian with no errors, the package's contents (deltactl, weights, unit, udev rules, the
# conffile, maintainer scripts, Depends), then installed into a scratch root with dpkg -x: the
# installed deltactl runs (--help) and checks the installed configuration (weights path moved into
# the scratch root).
# Usage: scripts/deploy/package_test.sh BUILD_DIR
set -euo pipefail
build=${1:?usage: package_test.sh BUILD_DIR}
fail() { echo "FAIL: $*" >&2; exit 1; }
command -v lintian >/dev/null || { echo "SKIP: no lintian (scripts/setup.sh installs it)"; exit 77; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
(cd "$build" && cpack -G DEB -B "$work/out" >"$work/cpack.log" 2>&1) || { cat "$work/cpack.log" >&2; fail "cpack"; }
deb=$(ls "$work"/out/deltactl_*.deb) || fail "no deltactl_*.deb"
# lintian: no errors (warnings and info are printed, not fatal).
if ! lintian --fail-on error --no-tag-display-limit "$deb" >"$work/lintian.log" 2>&1; then
  cat "$work/lintian.log" >&2; fail "lintian reports errors"
fi
grep -c '^W:' "$work/lintian.log" >"$work/warnings" || true
dpkg-deb --info "$deb" >"$work/info"
grep -q '^ Package: deltactl$' "$work/info" || fail "package name"
grep -q '^ Depends: .*adduser' "$work/info" || fail "Depends lacks adduser"
grep -q '^ Suggests: .*fpga-icestorm' "$work/info" || fail "Suggests lacks fpga-icestorm"
dpkg-deb --ctrl-tarfile "$deb" | tar -t >"$work/control"
for script in ./postinst ./prerm ./postrm ./conffiles; do grep -qx "$script" "$work/control" || fail "no $script"; done
dpkg-deb --ctrl-tarfile "$deb" | tar -xO ./conffiles | grep -qx /etc/deltactl/deltactl.conf || fail "conffiles"
dpkg-deb --ctrl-tarfile "$deb" | tar -xO ./postinst | grep -q 'adduser --system' || fail "postinst makes no user"
root="$work/root"
dpkg -x "$deb" "$root"
for file in usr/bin/deltactl usr/share/deltactl/weights/paper_like.json lib/systemd/system/deltactl.service \
            lib/udev/rules.d/70-delta-board.rules etc/deltactl/deltactl.conf usr/share/doc/deltactl/copyright \
            usr/share/doc/deltactl/lab_setup.md; do
  [[ -e "$root/$file" ]] || fail "package lacks /$file"
done
"$root/usr/bin/deltactl" --help >"$work/help" || fail "installed deltactl --help"
for command in doctor flash config; do grep -q "^  $command" "$work/help" || fail "installed deltactl lacks $command"; done
sed "s#/usr/share/deltactl#$root/usr/share/deltactl#" "$root/etc/deltactl/deltactl.conf" >"$work/deltactl.conf"
"$root/usr/bin/deltactl" config check --config "$work/deltactl.conf" >/dev/null || fail "installed config check"
echo "PASS: $(basename "$deb") ($(du -h "$deb" | cut -f1)): lintian no errors ($(cat "$work/warnings") warnings), installed deltactl runs"
